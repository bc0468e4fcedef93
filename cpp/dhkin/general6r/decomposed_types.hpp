// The matrix types of the general 6R solver that Eigen's decompositions take off the hot paths
// (the SVDs and small eigenproblems of cpp/eigen_instances.cpp), in a header of their own: that
// unit instantiates the decompositions once for these types and needs nothing else of the
// solver. Including the solver's headers there for these aliases cost 6-12 s of GCC's time (their
// inline functions and the Eigen expressions in them; docs/architecture.md, "Build time (helper
// i25ak)").
#pragma once

#include <Eigen/Core>

#include "dhkin/chain.hpp"                   // kDof
#include "dhkin/general6r/elimination.hpp"  // kQuantities

namespace dhkin::general6r {

// Largest null space split: the eight rows j <= 1 of the shift along j must hold m independent
// vectors. A larger cluster of equal eigenvalues is split in its eight smallest directions (more
// than eight roots sharing one joint value is a curve of solutions).
constexpr int kMaxSplit = 8;

// A cluster's split (null_space.hpp): its small eigenproblems (at most kMaxSplit square) and
// the low and the high rows of its shift operators (at most 9 x kMaxSplit).
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxSplit, kMaxSplit>;
using ShiftRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 9, kMaxSplit>;
// The right side's Q (back_substitution.hpp): its 14 quantities against the 8 products.
using RightSide = Eigen::Matrix<double, kQuantities, 8>;
// The Jacobian of the pose error at a root (full_steps.hpp; 6 x kDof, row-major).
using Jacobian = Eigen::Matrix<double, 6, kDof, Eigen::RowMajor>;

}  // namespace dhkin::general6r
