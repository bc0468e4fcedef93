// The exact chain's roots of a pose, found by a solver that does not depend on the families'
// branches: what a refined table's answer is completed with where its eight branch slots may not
// hold every root (extra_roots.hpp).
//
// An interface, so that the closed forms' translation unit does not compile the general 6R solver
// (cpp/dhkin/general6r/, built in its own unit: bindings_general6r.cpp implements it).
#pragma once

#include <vector>

#include "dhkin/chain.hpp"
#include "dhkin/frame.hpp"

namespace dhkin {

// One isolated root of the exact chain: joint values wrapped to (-pi, pi], its errors on the chain
// to DH frame n, and the smallest singular value of its Jacobian (linear rows over the lever).
struct ExactRoot {
  Joints q{};
  PoseError error;
  double sigma = 0.0;
};

class ExactRoots {
 public:
  virtual ~ExactRoots() = default;
  // Every root of T_dh (DH frame 0 -> DH frame n, a usable pose) verified at `verification` (m
  // and rad) on the exact chain to DH frame n, into `roots` (cleared first): none for a pose
  // beyond the chain's reach. Safe to call from several threads at once.
  virtual void find(const Frame& T_dh, double verification, std::vector<ExactRoot>& roots) const = 0;
  // A root whose sigma is at most this stands for a singular set at `verification` (a member of a
  // family of solutions or a double root), not for an isolated root.
  virtual double singular_band(double verification) const = 0;
};

}  // namespace dhkin
