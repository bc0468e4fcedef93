// A batch of poses answered as rows: every solution of each pose one after the other (all 2pi
// copies, or the one nearest the seed), with each pose's count. The batch of a refined table
// whose answers reach beyond the branch slots (extra_roots.hpp): a pose may have more solutions
// than the fixed-width layout of batch.hpp holds. The answer of solve_pose and expand, pose by
// pose.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dhkin/expand.hpp"
#include "dhkin/pipeline.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/row_batch.hpp"

namespace dhkin {

using RowsAnswer = RowBatch<Solution>;

// N poses (4 x 4 row-major, consecutive) with their seeds (kDof values each, `seed_stride` apart:
// 0 for one seed for all); stops at the first pose whose status is not usable.
inline RowsAnswer solve_rows(const Plan& plan, const TargetFrames& frames, const double* T,
                             std::size_t n, const double* seeds, std::size_t seed_stride,
                             double tolerance, bool copies) {
  RowsAnswer out;
  out.reserve(n, kBranches);
  for (std::size_t i = 0; i < n; ++i) {
    const Joints seed = seed_of(seeds, seed_stride, i);
    Branches branches;
    PoseInfo info;
    solve_pose(plan, frames, T + 16 * i, seed, tolerance, branches, info);
    if (info.status != kUsable) {
      out.reject(i, info.status);
      return out;
    }
    const long count = expand(plan, frames, T + 16 * i, seed, tolerance, copies, branches,
                              [&](const Solution& solution) {
                                out.rows.push_back(solution);
                                return true;
                              });
    out.answered(count, info.projection, info.dropped);
  }
  return out;
}

}  // namespace dhkin
