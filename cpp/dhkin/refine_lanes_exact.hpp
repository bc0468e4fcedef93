// refine() (newton.hpp) on kLanes independent starts at once, one start per lane, every lane
// giving exactly the bits refine() gives for its start.
//
// The convention: lane l of refine_lanes_exact(chain, shape, target, q, fixed, tolerance,
// settings) equals refine(chain, target, q_l, fixed, tolerance, settings) for q_l = lane l of q,
// in q (the best iterate) and in the errors returned. The lanes share the chain, the target, the
// `fixed` mask, the tolerance and the settings; each lane follows refine()'s control flow under
// masks: its own iterations, chain evaluations against the budget, damping (grown a hundredfold
// on a rejected step or a rank failure, divided by ten on a taken one), the kMaxJointStep
// shrink, polishing, stop_on_stall and the best iterate. The arithmetic is refine()'s, on the
// lane type, operation for operation (the chain's frames by chain_frames, which are fk_frames'
// with times_constant; sincos and atan2 give each lane the double's bits; simd.hpp: IEEE, no
// contraction, no autovectorisation), so a lane cannot tell it was not run alone. What differs is
// only work: a lane that has stopped, or that waits for its step while another lane retries a
// rejected one, computes values that are not used.
//
// Unlike refine_lanes (newton_lanes.hpp), which gives up a lane wherever refine() would damp, this
// runs the whole of refine(): for call sites that refine many starts of one chain and target and
// must answer as refine() does (the twin search's starts, the valley scan's held members).
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>

#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

// refine() per lane (see the convention above) from q (in place; each lane ends as its best
// iterate) towards `target` (DH frame 0 -> n), for a chain of kDof joints whose constant frames
// have the shapes `shape`. Lanes outside `active` take no part (q is left there as it is, the
// errors returned are not meaningful); give them a finite start, as their arithmetic still runs.
inline PoseErrorT<Lanes> refine_lanes_exact(const Chain& chain, const ChainShape& shape,
                                            const Frame& target, JointsT<Lanes>& q,
                                            const JointMask& fixed, double tolerance,
                                            const newton::Settings& settings = {},
                                            Mask active = uniform(true)) {
  using namespace newton;
  // An iterate: the chain's frames there, its error twist, errors and squared error size.
  struct Iterate {
    FrameT<Lanes> frames[kDof + 1];
    Lanes e[6];
    PoseErrorT<Lanes> error;
    Lanes size;

    // other's values in the lanes m
    void take(Mask m, const Iterate& other) {
      for (int f = 0; f <= kDof; ++f) {
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) {
            frames[f].R[r][c] = select(m, other.frames[f].R[r][c], frames[f].R[r][c]);
          }
          frames[f].p[r] = select(m, other.frames[f].p[r], frames[f].p[r]);
        }
      }
      for (int r = 0; r < 6; ++r) e[r] = select(m, other.e[r], e[r]);
      error.position = select(m, other.error.position, error.position);
      error.rotation = select(m, other.error.rotation, error.rotation);
      size = select(m, other.size, size);
    }
  };
  JointMotions<Lanes> motions;
  const auto evaluate = [&](const JointsT<Lanes>& at, Iterate& out) {
    joint_motions(chain, at.data(), motions);
    chain_frames(chain, shape, motions, out.frames);
    out.error = error_twist(out.frames[kDof], target, out.e);
    out.size = out.error.position * out.error.position + out.error.rotation * out.error.rotation;
  };
  // the current iterate, the step taken from it and the step just tried: swapped, not copied
  Iterate buffers[3];
  Iterate* now = &buffers[0];
  Iterate* trial = &buffers[1];
  Iterate* candidate = &buffers[2];
  Lanes J[6 * kDof], step[kDof];
  JointsT<Lanes> trial_q, candidate_q;
  const double goal = kRefineFraction * tolerance;
  const JointsT<Lanes> start = q;
  evaluate(q, *now);
  BestIterates best{q, now->error, now->size};
  const double floor = (goal / kMaxJointStep) * (goal / kMaxJointStep);
  Lanes damping(std::max(floor, settings.damping_start));
  Lanes evaluations(1.0);  // counts, exact in doubles
  const double budget = settings.budget;
  const double growth_squared = settings.growth * settings.growth;
  const Lanes raised_damping(kDampingStart + floor);
  // A lane is running until refine() would have returned for its start; lanes that stopped
  // still compute (their values unused), and only their best iterate is kept.
  Mask running = active;
  Mask polishing = uniform(false);
  for (int iteration = 0; iteration < kMaxSteps; ++iteration) {
    running = running && !(evaluations >= budget || now->size == 0.0);
    if (!any(running)) break;
    polishing = polishing || (now->error.position <= goal && now->error.rotation <= goal);
    jacobian(chain, now->frames, J);
    // refine()'s inner loop: each lane solves, tries and, while rejected, damps and solves again
    Mask waiting = running;  // no step taken yet, not given up
    Mask taken = uniform(false);
    bool first_try = true;
    while (any(waiting)) {
      const Mask solved = waiting && least_squares(J, now->e, fixed, damping, step);
      Mask accepted = uniform(false);
      if (any(solved)) {
        Lanes longest(0.0);
        for (int a = 0; a < kDof; ++a) longest = max(longest, abs(step[a]));
        const Lanes shrink = select(longest > kMaxJointStep, kMaxJointStep / longest, Lanes(1.0));
        for (int a = 0; a < kDof; ++a) candidate_q[a] = q[a] + shrink * step[a];
        evaluate(candidate_q, *candidate);
        evaluations = select(solved, evaluations + 1.0, evaluations);
        accepted = solved && candidate->size <= growth_squared * now->size;
        if (first_try) {  // lanes not accepted write theirs when they are
          std::swap(trial, candidate);
          trial_q = candidate_q;
        } else {
          for (int a = 0; a < kDof; ++a) trial_q[a] = select(accepted, candidate_q[a], trial_q[a]);
          trial->take(accepted, *candidate);
        }
      }
      first_try = false;
      taken = taken || accepted;
      const Mask rejected = waiting && !accepted;
      damping = select(rejected, max(100.0 * damping, raised_damping), damping);
      const Mask given_up = rejected && (damping > kDampingLimit || evaluations >= budget);
      waiting = rejected && !given_up;
    }
    running = running && taken;  // refine() stops where no step was taken
    const Mask no_gain = !(trial->size * kPolishGain <= now->size);
    const Mask stalled = trial->size <= now->size && no_gain;
    const Mask stop =
        running && ((polishing && no_gain) || (settings.stop_on_stall && stalled));
    // at the rounding of the arithmetic: the trial is kept if it is the best
    best.take(stop && trial->size < best.size, trial_q, trial->error, trial->size);
    running = running && !stop;
    if (!any(running)) break;
    // the step taken (lanes that stopped never step again: their iterate is not used)
    q = trial_q;
    std::swap(now, trial);
    damping = select(damping > kDampingStart, max(0.1 * damping, Lanes(floor)), Lanes(floor));
    best.take(running && now->size < best.size, q, now->error, now->size);
  }
  for (int a = 0; a < kDof; ++a) q[a] = select(active, best.q[a], start[a]);
  return best.error;
}

}  // namespace dhkin
