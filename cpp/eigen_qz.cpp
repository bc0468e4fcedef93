// Eigen's real QZ for the general 6R's 24 x 24 pencils at moved poses (eigenvalues.hpp),
// instantiated once here: ~30 s of GCC's time at -O3, in a unit of its own so that it compiles
// beside the others (cpp/eigen_instances.cpp says why).
#include <Eigen/Dense>

#include "dhkin/general6r/hessenberg_qr.hpp"  // Matrix24
#include "dhkin/general6r/qz_shifts.hpp"      // QZ's exceptional shifts, a sequence per pencil

template Eigen::GeneralizedEigenSolver<dhkin::general6r::Matrix24>&
Eigen::GeneralizedEigenSolver<dhkin::general6r::Matrix24>::compute(const dhkin::general6r::Matrix24&,
                                                                  const dhkin::general6r::Matrix24&,
                                                                  bool);
