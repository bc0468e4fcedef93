// The "random" shifts of Eigen's real QZ, made a fixed sequence per pencil.
//
// Eigen's RealQZ (GeneralizedEigenSolver) takes an "extremely exceptional shift" when one
// eigenvalue has not converged after 24 iterations: three numbers from
// Eigen::internal::random<double>, i.e. from the C library's std::rand(), whose state is global
// to the process. The eigenvalues of a pencil that needs such shifts then depend on every QZ run
// before it (and on other threads' runs): one pose solved twice could return different roots
// (members of a curve of solutions 1e-8 rad apart, or a different count of them). Here
// random<double> draws from a thread's own generator instead, which QZ's caller restarts before
// each pencil (QzShifts::restart): the shifts, hence the eigenvalues, depend on the pencil alone.
//
// Eigen calls random<double> nowhere else that the core instantiates (RealQZ is the only user in
// its Eigenvalues, SVD, QR and LU modules). Include this header before any use of
// Eigen::internal::random<double> in a unit (eigenvalues.hpp and eigen_qz.cpp do).
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace dhkin::general6r {

// A 64-bit linear congruential generator (Knuth's MMIX constants), its top 53 bits as a double
// in [0, 1): the shifts only need to break QZ's cycle, not to be good random numbers.
struct QzShifts {
  static constexpr std::uint64_t kStart = 0x853c49e6748fea9bULL;
  std::uint64_t state = kStart;

  void restart() { state = kStart; }
  double next_unit() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  }
};

// One generator per thread (the batch solves poses on several).
inline thread_local QzShifts qz_shifts;

}  // namespace dhkin::general6r

namespace Eigen::internal {

template <>
struct random_impl<double> {
  static double run(const double& x, const double& y) {
    return x + (y - x) * dhkin::general6r::qz_shifts.next_unit();
  }
  static double run() { return run(-1.0, 1.0); }
};

}  // namespace Eigen::internal
