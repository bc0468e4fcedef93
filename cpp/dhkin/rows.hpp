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

namespace dhkin {

struct RowsAnswer {
  std::vector<Solution> rows;
  std::vector<std::int64_t> counts;   // per pose answered
  std::vector<double> projection;     // per pose answered
  std::vector<std::int64_t> dropped;  // per pose answered
  long rejected = -1;                 // the first pose whose status is not usable, or -1
  int status = 0;                     // its status
};

// N poses (4 x 4 row-major, consecutive) with their seeds (kDof values each, `seed_stride` apart:
// 0 for one seed for all); stops at the first pose whose status is not usable.
inline RowsAnswer solve_rows(const Plan& plan, const TargetFrames& frames, const double* T,
                             std::size_t n, const double* seeds, std::size_t seed_stride,
                             double tolerance, bool copies) {
  RowsAnswer out;
  out.counts.reserve(n);
  out.projection.reserve(n);
  out.dropped.reserve(n);
  out.rows.reserve(n * kBranches);
  for (std::size_t i = 0; i < n; ++i) {
    Joints seed;
    for (int j = 0; j < kDof; ++j) seed[j] = seeds[i * seed_stride + j];
    Branches branches;
    PoseInfo info;
    solve_pose(plan, frames, T + 16 * i, seed, tolerance, branches, info);
    if (info.status != kUsable) {
      out.rejected = static_cast<long>(i);
      out.status = info.status;
      return out;
    }
    const long count = expand(plan, frames, T + 16 * i, seed, tolerance, copies, branches,
                              [&](const Solution& solution) {
                                out.rows.push_back(solution);
                                return true;
                              });
    out.counts.push_back(count);
    out.projection.push_back(info.projection);
    out.dropped.push_back(info.dropped);
  }
  return out;
}

}  // namespace dhkin
