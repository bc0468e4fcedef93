// Eigen's decompositions that the core calls off its hot paths, instantiated once here.
//
// The headers that call them declare these member functions `extern template`, so the units that
// include them do not instantiate them again. GCC spends seconds to tens of seconds of CPU on
// each (Eigen's real QZ for 24 x 24 alone ~30 s at -O3): compiled inside
// cpp/bindings_general6r.cpp they made it a 225 s unit, most of `pip install .`'s time on two
// cores; here they compile beside the bindings (docs/architecture.md, "Build time"). The hot
// paths' decompositions (the 12 x 12 and 6 x 6 LUs, the right side's Householder QR) stay inline
// where they are used. Eigen's real QZ has a unit of its own (cpp/eigen_qz.cpp), so that the two
// cores of a small machine share the work.
//
// Only the header that names the matrix types is included: the callers' headers would bring
// every inline function of the solver into this unit too (6-12 s of GCC's time, which
// decomposed_types.hpp saves).
#include <Eigen/Dense>

#include "dhkin/chain.hpp"                       // kDof
#include "dhkin/general6r/decomposed_types.hpp"  // Small, ShiftRows, RightSide, Jacobian

// Inside Eigen's class scopes a parameter's unqualified name would find Eigen's own names first
// (Eigen::Small is an enumerator): the types are spelled out in full.

// A cluster's split into its roots' monomial vectors (null_space.hpp).
template Eigen::EigenSolver<dhkin::general6r::Small>&
Eigen::EigenSolver<dhkin::general6r::Small>::compute(const Eigen::EigenBase<dhkin::general6r::Small>&,
                                                   bool);
template Eigen::EigenSolver<dhkin::general6r::Small>::EigenvectorsType
Eigen::EigenSolver<dhkin::general6r::Small>::eigenvectors() const;
template Eigen::JacobiSVD<dhkin::general6r::ShiftRows>&
Eigen::JacobiSVD<dhkin::general6r::ShiftRows>::compute(const dhkin::general6r::ShiftRows&, unsigned int);
// The right side's rank where its QR cannot decide it (right_side.hpp).
template Eigen::JacobiSVD<dhkin::general6r::RightSide>&
Eigen::JacobiSVD<dhkin::general6r::RightSide>::compute(const dhkin::general6r::RightSide&, unsigned int);
// A root's singular values below the band, and the valley's (roots.hpp, valley.hpp).
template Eigen::JacobiSVD<dhkin::general6r::Jacobian>&
Eigen::JacobiSVD<dhkin::general6r::Jacobian>::compute(const dhkin::general6r::Jacobian&, unsigned int);
template void Eigen::PartialPivLU<Eigen::Matrix<double, dhkin::kDof, dhkin::kDof>>::compute();
// The weakest direction of a continuation's Jacobian (continuation.hpp).
template Eigen::JacobiSVD<Eigen::Matrix<double, 6, dhkin::kDof>>&
Eigen::JacobiSVD<Eigen::Matrix<double, 6, dhkin::kDof>>::compute(
    const Eigen::Matrix<double, 6, dhkin::kDof>&, unsigned int);
