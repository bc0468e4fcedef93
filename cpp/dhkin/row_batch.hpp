// A batch of poses answered as rows: every solution of each pose one after the other, with each
// pose's count, projection and dropped count, and where the batch stopped. Shared by the
// closed-form batch of a table whose answers reach beyond the branch slots (rows.hpp) and the
// general 6R solver's batch (general6r/solver.hpp); `Row` is each one's solution type.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dhkin/chain.hpp"

namespace dhkin {

template <class Row>
struct RowBatch {
  std::vector<Row> rows;
  std::vector<std::int64_t> counts;   // per pose answered
  std::vector<double> projection;     // per pose answered
  std::vector<std::int64_t> dropped;  // per pose answered
  long rejected = -1;                 // the first pose whose status is not usable, or -1
  int status = 0;                     // its status

  // Room for n poses of about `rows_per_pose` rows each.
  void reserve(std::size_t n, std::size_t rows_per_pose) {
    counts.reserve(n);
    projection.reserve(n);
    dropped.reserve(n);
    rows.reserve(n * rows_per_pose);
  }

  // One pose answered: its count of the rows just added, its projection and dropped count.
  void answered(std::int64_t count, double pose_projection, std::int64_t pose_dropped) {
    counts.push_back(count);
    projection.push_back(pose_projection);
    dropped.push_back(pose_dropped);
  }

  // The batch stops at pose i, rejected with `why`.
  void reject(std::size_t i, int why) {
    rejected = static_cast<long>(i);
    status = why;
  }
};

// Pose i's seed: kDof values `seed_stride` apart (0: one seed for every pose).
inline Joints seed_of(const double* seeds, std::size_t seed_stride, std::size_t i) {
  Joints seed;
  for (int j = 0; j < kDof; ++j) seed[j] = seeds[i * seed_stride + j];
  return seed;
}

}  // namespace dhkin
