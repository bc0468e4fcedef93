// A batch of poses without 2pi copies (one solution per branch, its in-limit copy nearest the
// seed), written straight into the caller's result arrays: the answer of expand(copies = false)
// after solve_pose, pose by pose, bit for bit.
//
// Poses go by blocks of kLanes through the direct path in lanes (block.hpp); the nearest copy of
// each branch is found in lanes too (copies.hpp), and a copy set onto a limit or whose branch
// error is within kCopyMargin of the tolerance is verified again, one at a time, as expand does.
// A pose the block declines goes through the pipeline and expand (pipeline.hpp, expand.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

#include "dhkin/block.hpp"
#include "dhkin/expand.hpp"
#include "dhkin/pipeline.hpp"
#include "dhkin/plan.hpp"

namespace dhkin {

// The caller's arrays for N poses: q (N, kBranches, kDof), valid, branch, flags (N, kBranches),
// errors (N, kBranches, 2), projection and dropped (N), uninitialised: every slot of a pose that
// is answered is written, those past its last solution with the empty values (zeros, valid
// false, branch -1). A rejected pose and those after it are not written (the batch stops).
struct NearestOutputs {
  double* q;
  bool* valid;
  std::int16_t* branch;
  std::uint8_t* flags;
  double* errors;
  double* projection;
  std::int64_t* dropped;
};

// How a batch went: the first pose whose status is not usable (or -1) and that status, and the
// most solutions of any pose.
struct BatchReport {
  long rejected = -1;
  int status = 0;
  int width = 0;
};

namespace batch {

// rows[l][j] = v[j] lane l, for the kDof joint vectors v (rows[l][j] for j >= kDof is left
// undefined): one joint vector per lane out of a by-joint array of lanes, for the output slots
// (put_joints copies a row). With AVX-512 the rows come from an 8 x 8 transposition in
// registers (24 two-register permutations) in place of a gather per slot.
DHKIN_INLINE void joint_rows(const Lanes (&v)[kDof], double (*rows)[kLanes]) {
#if defined(__AVX512F__)
  static_assert(kDof <= 8 && simd::kParts == 1, "one vector");
  __m512d r[8];
  for (int j = 0; j < 8; ++j) r[j] = j < kDof ? (__m512d)v[j].v[0] : _mm512_setzero_pd();
  // pairs of rows interleaved, then pairs of pairs, then halves: row l of the result is lane
  // l of every input
  __m512d t[8], u[8];
  for (int k = 0; k < 4; ++k) {
    t[2 * k] = _mm512_unpacklo_pd(r[2 * k], r[2 * k + 1]);      // r0[0] r1[0] r0[2] r1[2] ...
    t[2 * k + 1] = _mm512_unpackhi_pd(r[2 * k], r[2 * k + 1]);  // r0[1] r1[1] r0[3] r1[3] ...
  }
  const __m512i low_pairs = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
  const __m512i high_pairs = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
  for (int h = 0; h < 2; ++h) {  // rows 0-3 (h = 0) and 4-7
    u[4 * h + 0] = _mm512_permutex2var_pd(t[4 * h], low_pairs, t[4 * h + 2]);       // lanes 0, 4
    u[4 * h + 2] = _mm512_permutex2var_pd(t[4 * h], high_pairs, t[4 * h + 2]);      // lanes 2, 6
    u[4 * h + 1] = _mm512_permutex2var_pd(t[4 * h + 1], low_pairs, t[4 * h + 3]);   // lanes 1, 5
    u[4 * h + 3] = _mm512_permutex2var_pd(t[4 * h + 1], high_pairs, t[4 * h + 3]);  // lanes 3, 7
  }
  const __m512i low_half = _mm512_set_epi64(11, 10, 9, 8, 3, 2, 1, 0);
  const __m512i high_half = _mm512_set_epi64(15, 14, 13, 12, 7, 6, 5, 4);
  for (int l = 0; l < 4; ++l) {
    _mm512_store_pd(rows[l], _mm512_permutex2var_pd(u[l], low_half, u[4 + l]));
    _mm512_store_pd(rows[4 + l], _mm512_permutex2var_pd(u[l], high_half, u[4 + l]));
  }
#else
  for (int j = 0; j < kDof; ++j) {
    alignas(64) double values[kLanes];
    v[j].store(values);
    for (int l = 0; l < kLanes; ++l) rows[l][j] = values[l];
  }
#endif
}

// Stores into the result arrays that bypass the caches (SSE2 non-temporal stores, 16 bytes each,
// to 16-byte aligned addresses), for a batch whose result exceeds the caches (streamable): there
// an ordinary store first reads its line from memory, which stalled the loop that writes the
// slots (perf: the store after each slot's joint values). Every answered pose's q row (384
// bytes) and errors (128 bytes) are written whole (solutions, then empty slots), so the lines
// fill in the write-combining buffers. solve_nearest ends with a store fence.
#if defined(__SSE2__)
constexpr bool kStreamed = true;
DHKIN_INLINE void stream_pair(double* to, double a, double b) {
  _mm_stream_pd(to, _mm_set_pd(b, a));
}
DHKIN_INLINE void stream_fence() { _mm_sfence(); }
#else
constexpr bool kStreamed = false;
DHKIN_INLINE void stream_pair(double* to, double a, double b) { to[0] = a, to[1] = b; }
DHKIN_INLINE void stream_fence() {}
#endif

// The size of this core's second-level cache in bytes (the operating system's figure; where it
// gives none, 1 MiB, a common size).
inline std::size_t level2_cache_bytes() {
  static const std::size_t bytes = [] {
    long size = -1;
#if defined(_SC_LEVEL2_CACHE_SIZE)
    size = sysconf(_SC_LEVEL2_CACHE_SIZE);
#endif
    return size > 0 ? static_cast<std::size_t>(size) : std::size_t{1} << 20;
  }();
  return bytes;
}

// Whether a call writing n poses streams its q rows and errors: when these exceed the
// second-level cache (a smaller result stays in the caches for its reader, and is written
// there), and the arrays take stream_pair (16-byte aligned: numpy's arrays are).
inline bool streamable(const NearestOutputs& out, std::size_t n) {
  const auto aligned = [](const void* p) { return reinterpret_cast<std::uintptr_t>(p) % 16 == 0; };
  const std::size_t bytes = n * kBranches * (kDof + 2) * sizeof(double);
  return kStreamed && bytes > level2_cache_bytes() && aligned(out.q) && aligned(out.errors);
}

// to[j] = row[j] for the kDof joints (row: 16-byte aligned, kLanes values), streamed or not.
DHKIN_INLINE void put_joints(double* to, const double* row, bool streamed) {
  static_assert(kDof % 2 == 0, "pairs");
  if (streamed) {
    for (int j = 0; j < kDof; j += 2) stream_pair(to + j, row[j], row[j + 1]);
  } else {
    for (int j = 0; j < kDof; ++j) to[j] = row[j];
  }
}

// Slots [slot, kBranches) of pose i get the empty values (q and errors streamed or not).
inline void put_empty(const NearestOutputs& out, std::size_t i, int slot, bool streamed = false) {
  alignas(16) static const double kZeros[kDof] = {};
  for (std::size_t k = i * kBranches + static_cast<std::size_t>(slot); k < (i + 1) * kBranches;
       ++k) {
    put_joints(out.q + k * kDof, kZeros, streamed);
    out.valid[k] = false;
    out.branch[k] = -1;
    out.flags[k] = 0;
    if (streamed) {
      stream_pair(out.errors + 2 * k, 0.0, 0.0);
    } else {
      out.errors[2 * k] = 0.0;
      out.errors[2 * k + 1] = 0.0;
    }
  }
}

// Slot `slot` of pose i gets `solution`.
inline void put(const NearestOutputs& out, std::size_t i, int slot, const Solution& solution) {
  const std::size_t k = i * kBranches + static_cast<std::size_t>(slot);
  for (int j = 0; j < kDof; ++j) out.q[k * kDof + j] = solution.q[j];
  out.valid[k] = true;
  out.branch[k] = static_cast<std::int16_t>(solution.branch);
  out.flags[k] = solution.flags;
  out.errors[2 * k] = solution.error.position;
  out.errors[2 * k + 1] = solution.error.rotation;
}

// The nearest copies of a block's answered poses (expand's copies = false, in lanes): slot by
// slot into `out`, poses first + l.
inline void put_nearest(const Plan& plan, const BlockAnswer& answer, double tolerance,
                        const NearestOutputs& out, std::size_t first, int count, bool streamed,
                        BatchReport& report) {
  const double slack = tolerance / plan.lever;
  tolerance = plan.verification_tolerance(tolerance);
  // by branch, then lane: the copies, whether each exists and must be verified again, the
  // branch's errors and flags
  alignas(64) double q[kBranches][kLanes][kLanes];  // [b][l]: lane l's joint vector (joint_rows)
  alignas(64) double position[kBranches][kLanes], rotation[kBranches][kLanes];
  alignas(64) std::int64_t exists[kBranches][kLanes], recheck[kBranches][kLanes];
  alignas(64) std::int64_t flags[kBranches][kLanes];
  for (int b = 0; b < kBranches; ++b) {
    Mask found = answer.ok[b];
    std::memcpy(exists[b], &found.v, sizeof exists[b]);
    if (!any(found)) {  // defined values for the loop below (which writes, then drops them)
      std::memset(q[b], 0, sizeof q[b]);
      std::memset(recheck[b], 0, sizeof recheck[b]);
      std::memset(flags[b], 0, sizeof flags[b]);
      std::memset(position[b], 0, sizeof position[b]);
      std::memset(rotation[b], 0, sizeof rotation[b]);
      continue;
    }
    Mask clipped = every_lane<Lanes>(false);
    Lanes copies[kDof];
    for (int j = 0; j < kDof; ++j) {
      const bool revolute = plan.revolute(j);
      const Lanes value = answer.q[b][j];
      const NearestTurn<Lanes> nearest =
          nearest_turn(plan.limits[j], revolute, value, slack, answer.seed[j]);
      found = found && nearest.exists;
      const Lanes copy = placed(plan.limits[j], revolute, value, nearest.turn);
      clipped = clipped || copy != shifted(revolute, value, nearest.turn);
      copies[j] = copy;
    }
    joint_rows(copies, q[b]);
    const Mask again = clipped || answer.errors[b].largest() > tolerance - kCopyMargin;
    std::memcpy(exists[b], &found.v, sizeof exists[b]);
    std::memcpy(recheck[b], &again.v, sizeof recheck[b]);
    std::memcpy(flags[b], &answer.flags[b].v, sizeof flags[b]);
    answer.errors[b].position.store(position[b]);
    answer.errors[b].rotation.store(rotation[b]);
  }
  // pose by pose: each solution written straight into its slot; a branch without a copy is
  // written too and then overwritten by the next one (its slot does not advance), so the loop
  // does not branch on which copies exist (they vary from pose to pose). The slots past the
  // last solution get the empty values.
  for (int l = 0; l < count; ++l) {
    if (!answer.answered[l]) continue;
    const std::size_t i = first + static_cast<std::size_t>(l);
    const std::size_t row = i * kBranches;
    double* const q_out = out.q + row * kDof;
    double* const errors_out = out.errors + 2 * row;
    int slot = 0;
    for (int b = 0; b < kBranches; ++b) {
      const bool exists_b = exists[b][l] != 0;
      double* const q_slot = q_out + slot * kDof;
      put_joints(q_slot, q[b][l], streamed);
      PoseError error{position[b][l], rotation[b][l]};
      bool kept = exists_b;
      if ((exists[b][l] & recheck[b][l]) != 0) {  // rare: no branch on exists_b alone
        error = check(plan.chain, q[b][l], lane(answer.T_at, l));
        kept = error.within(tolerance);
      }
      out.valid[row + slot] = true;
      out.branch[row + slot] = static_cast<std::int16_t>(b);
      out.flags[row + slot] = static_cast<std::uint8_t>(flags[b][l]);
      if (streamed) {
        stream_pair(errors_out + 2 * slot, error.position, error.rotation);
      } else {
        errors_out[2 * slot] = error.position;
        errors_out[2 * slot + 1] = error.rotation;
      }
      slot += kept ? 1 : 0;
    }
    if (slot < kBranches) put_empty(out, i, slot, streamed);
    out.projection[i] = answer.projection[l];
    out.dropped[i] = 0;
    report.width = std::max(report.width, slot);
  }
}

// Pose i through the pipeline and expand(copies = false), into `out`.
inline void put_pipeline(const Plan& plan, const TargetFrames& frames, const double* T,
                         const Joints& seed, double tolerance, const NearestOutputs& out,
                         std::size_t i, BatchReport& report) {
  Branches branches;
  PoseInfo info;
  solve_branches(plan, frames, T, seed, tolerance, branches, info);
  int slot = 0;
  expand(plan, frames, T, seed, tolerance, false, branches, [&](const Solution& solution) {
    put(out, i, slot++, solution);
    return true;
  });
  put_empty(out, i, slot);
  out.projection[i] = info.projection;
  out.dropped[i] = info.dropped;
  report.width = std::max(report.width, slot);
}

}  // namespace batch

// N poses (4 x 4 row-major, consecutive) with their seeds (kDof values each, `seed_stride`
// apart: 0 for one seed for all) into `out`; stops at the first pose whose status is not usable
// (report.rejected).
inline BatchReport solve_nearest(const Plan& plan, const TargetFrames& frames, const double* T,
                                 std::size_t n, const double* seeds, std::size_t seed_stride,
                                 double tolerance, const NearestOutputs& out) {
  BatchReport report;
  const auto seed_of = [&](std::size_t i) {
    Joints seed;
    for (int j = 0; j < kDof; ++j) seed[j] = seeds[i * seed_stride + j];
    return seed;
  };
  // one answer and one set of candidates for every block: each block writes every value that is
  // read afterwards, and their zero initialisation (some 11 kB) is then paid once per call
  BlockAnswer answer;
  CandidatesT<Lanes> found;
  KnownTurnsT<Lanes> known;
  const bool streamed = batch::streamable(out, n);
  for (std::size_t first = 0; first < n; first += kLanes) {
    PoseBlock poses;
    poses.count = static_cast<int>(std::min<std::size_t>(kLanes, n - first));
    for (int l = 0; l < poses.count; ++l) {
      poses.T[l] = T + 16 * (first + l);
      poses.seed[l] = seeds + (first + l) * seed_stride;
    }
    if (!plan.refine) {
      direct_block(plan, frames, poses, tolerance, answer, found, known);
      batch::put_nearest(plan, answer, tolerance, out, first, poses.count, streamed, report);
    }
    for (int l = 0; l < poses.count; ++l) {
      if (!plan.refine && answer.answered[l]) continue;
      const std::size_t i = first + static_cast<std::size_t>(l);
      const Joints seed = seed_of(i);
      int status = plan.refine ? 0 : answer.status[l];
      if (plan.refine) {
        double projection = 0.0;
        PoseTargets targets;
        pose_targets(frames, T + 16 * i, seed, status, projection, targets);
      }
      if (status != kUsable) {
        report.rejected = static_cast<long>(i);
        report.status = status;
        batch::stream_fence();
        return report;
      }
      batch::put_pipeline(plan, frames, T + 16 * i, seed, tolerance, out, i, report);
    }
  }
  batch::stream_fence();
  return report;
}

}  // namespace dhkin
