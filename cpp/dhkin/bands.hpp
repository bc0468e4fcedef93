// Singularity bits and the bands that decide near-singular behaviour (shared by every family).
//
// * kFlagBand: a solution is flagged wrist / elbow / shoulder when the family's measure of that
//   singularity is at most this: |sin| of the wrist angle (axes 4 and 6) or of the elbow angle
//   (upper arm and forearm, from stretched or folded), or the wrist centre's distance from the
//   plane of axes 1 and 2 divided by the table's length scale. It is a report, nothing more: what
//   the solver returns is decided by the verification tolerance.
// * kMergeAngle: two roots of one equation (the two shoulder or elbow branches) closer than twice
//   this angle are one solution; collapsing them moves the pose by a second-order amount,
//   ~kMergeAngle^2 = 1e-12 (m per m of arm, and rad), a thousandth of the default tolerance, while
//   rounding alone spreads the two roots of a pose exactly on the boundary by ~1e-8 rad.
#pragma once

#include <cstdint>

namespace dhkin {

// Singularity bits (the same values as dhkin.ik.result: WRIST, ELBOW, SHOULDER).
constexpr std::uint8_t kWrist = 1, kElbow = 2, kShoulder = 4;
// The bits of the singularities where a joint is free.
constexpr std::uint8_t kFree = kWrist | kElbow | kShoulder;
// Beside them in a family's `near` bits: the candidate was clamped onto a reach boundary (it is
// not an exact solution of the ideal model, only a start for the refinement).
constexpr std::uint8_t kClamped = 8;

constexpr double kFlagBand = 1e-6;
constexpr double kMergeAngle = 1e-6;

}  // namespace dhkin
