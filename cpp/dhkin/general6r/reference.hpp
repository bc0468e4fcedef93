// An independent reference for the roots of a six-revolute chain: Newton's method on the exact
// chain from many fixed starts, no elimination (the validator's and the acceptance script's
// check that the general 6R solver misses no root; docs/general6r.md, "Checking completeness").
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified;
// the target is that point's pose in DH frame 0 (metres).
#pragma once

#include <vector>

#include "dhkin/general6r/roots.hpp"

namespace dhkin::general6r {

// Newton from every start towards `target`; the distinct joint vectors (wrapped to (-pi, pi])
// that verify at `tolerance`, at most `most` of them. The starts stop early once `patience` of
// them in a row found no new root. Two are one root when they lie within kMaxJointStep of each
// other and their midpoint verifies too (the solver's merging rule). Each root is then polished
// by monotone Newton steps as far as the arithmetic allows: an isolated root does not move, but a
// point that verified in the cloud around a singular root moves onto the singular set, so that
// its Jacobian says what it is.
inline std::vector<Joints> multistart(const Chain& chain, const Frame& target,
                                      const std::vector<Joints>& starts, double tolerance,
                                      std::size_t patience, std::size_t most) {
  std::vector<Joints> roots;
  std::size_t last_new = 0;
  for (std::size_t index = 0; index < starts.size(); ++index) {
    if (index - last_new >= patience) break;
    Joints q = starts[index];
    refine(chain, target, q, JointMask{}, tolerance, {newton::kBudget, newton::kGrowth, 0.0});
    if (!check(chain, q.data(), target).within(tolerance)) continue;
    q = wrapped(q);
    bool known = false;
    for (const Joints& other : roots) {
      if (one_root(chain, target, q, other, tolerance)) {
        known = true;
        break;
      }
    }
    if (known || roots.size() >= most) continue;
    roots.push_back(q);
    last_new = index;
  }
  for (Joints& root : roots) {
    refine(chain, target, root, JointMask{}, 0.0, {newton::kBudget, newton::kMonotone, 0.0});
    root = wrapped(root);
  }
  return roots;
}

}  // namespace dhkin::general6r
