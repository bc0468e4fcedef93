// The closed-form solver of one table: its plan, and the plan at the TCP of a call's frames.
#pragma once

#include <cstring>
#include <memory>
#include <utility>

#include "dhkin/plan.hpp"
#include "dhkin/pose.hpp"

namespace dhkin {

class ClosedFormSolver {
 public:
  // `frames`: the table's own base and tool (no TCP given), whose plan is kept ready.
  ClosedFormSolver(Plan plan, const TargetFrames& frames)
      : plan_(std::move(plan)), default_frames_(frames) {
    if (frames.at_tcp) plan_at_default_ = plan_.at_point(frames.tcp_point);
  }

  const Plan& plan() const { return plan_; }

  // The exact roots that complete a refined table's answers (extra_roots.hpp), held here and set
  // in every plan this solver gives.
  void attach_exact_roots(std::shared_ptr<const ExactRoots> roots) {
    exact_roots_ = std::move(roots);
    plan_.exact_roots = plan_at_default_.exact_roots = exact_roots_.get();
  }
  const TargetFrames& default_frames() const { return default_frames_; }

  // The plan whose chains end at the frames' TCP point. `storage` holds a new plan when one is
  // needed (a TCP other than the table's own tool).
  const Plan& plan_for(const TargetFrames& frames, Plan& storage) const {
    if (!frames.at_tcp) return plan_;
    if (same_point(frames.tcp_point, default_frames_.tcp_point) && default_frames_.at_tcp) {
      return plan_at_default_;
    }
    storage = plan_.at_point(frames.tcp_point);
    return storage;
  }

 private:
  static bool same_point(const Vec3& a, const Vec3& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
  }

  Plan plan_;
  TargetFrames default_frames_;
  Plan plan_at_default_;
  std::shared_ptr<const ExactRoots> exact_roots_;
};

}  // namespace dhkin
