// The general 6R solver's roots at the crossings of a curve of solutions with a second singular
// set (docs/general6r.md, "Curves crossing").
//
// A target a hair off a pose with a curve of solutions (a description rounded to 10 significant
// digits) leaves the curve a floor whose every point misses the target by the same small error
// (F is one pose all along the curve): the folded M-430iA/2P at q = (90, 0, 180, 0, 90, -90)
// deg, 1.2e-10 m off its q2-curve. Where the curve meets a second singular set (its Jacobian of
// rank 4 or less there: the folded arm's q2-curve at q5 = 0; the HC10's straight-up q1 + q4
// curve at q1 = 90 deg, q5 = 0, rank 3), the error is quadratic in the extra weak directions,
// and off the curve, within ~sqrt(error / curvature) (~5e-5 rad) of that point, the target is
// reached about as well as on the curve itself: Newton from a start there stalls on points
// (sigma_min 1e-6 .. 8e-6, isolated by dhkin validate's measure) that no member of the curve
// away from the crossing is tied to by a segment of solutions. The crossing itself is: the
// straight segment from it to each such point verifies. So each crossing of such a curve is a
// root of its own, found by tracing the curve from the elimination's members of it and locating
// where the Jacobian's second smallest singular value vanishes.
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified;
// `target` its pose in DH frame 0 (metres).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "dhkin/general6r/members.hpp"
#include "dhkin/general6r/roots.hpp"
#include "dhkin/general6r/valley.hpp"
#include "dhkin/right_svd.hpp"

namespace dhkin::general6r {

// Steps locating a crossing between the two points beside the traced point nearest it. The
// second singular value along the curve is |lambda| of a smooth lambda that vanishes at the
// crossing: a V of equal slopes, whose bottom the V through three points of it puts within the
// square of their spread (as the secant method converges). A true crossing comes down to the
// singular value's rounding (~1e-10 .. 1e-8 on the M-430iA/2P's and the HC10's) within two to
// four such steps, where the V's next bottom is no lower; the cap gives up a minimum that
// does not reach zero (no crossing; 12 golden-section steps, taken where the V's bottom falls
// outside its side, would shrink its bracket to 0.618^12 = 3e-3 of its length).
constexpr int kCrossingIterations = 12;
// A golden-section step's ratio (3 - sqrt(5)) / 2, where the V's bottom falls outside the side
// it was drawn for.
constexpr double kGolden = 0.3819660112501051;

// A point of a curve of solutions: its tangent (the Jacobian's weakest right singular vector,
// oriented along the previous point's) and the second smallest singular value, which falls to
// zero (linearly in the arc length, a V) where the curve crosses a second singular set.
struct CurvePoint {
  Joints q{};
  Vector6d tangent = Vector6d::Zero();
  double smallest = 0.0;
  double second = 0.0;
};

inline CurvePoint curve_point(const Chain& chain, const Joints& q, double lever,
                              const Vector6d& previous) {
  const RightSvd svd = right_svd(scaled_jacobian(chain, q, lever));
  CurvePoint out;
  out.q = q;
  out.tangent = svd.V.col(kDof - 1);
  if (out.tangent.dot(previous) < 0.0) out.tangent = -out.tangent;
  out.smallest = svd.values(kDof - 1);
  out.second = svd.values(kDof - 2);
  return out;
}

// The point of the curve along the two chords before -> middle -> after at s in [0, 2] (s <= 1
// on the first), settled onto the curve across it (settle_across above the band: near a
// crossing the second weak direction is left alone).
inline CurvePoint on_chords(const Chain& chain, const Frame& target, const Joints& before,
                            const Joints& middle, const Joints& after, double s, double lever,
                            double band, const Vector6d& previous) {
  const Joints& a = s <= 1.0 ? before : middle;
  const Joints& b = s <= 1.0 ? middle : after;
  const double t = s <= 1.0 ? s : s - 1.0;
  Joints q;
  for (int j = 0; j < kDof; ++j) q[j] = a[j] + t * wrap(b[j] - a[j]);
  settle_across(chain, target, q, lever, band);
  return curve_point(chain, q, lever, previous);
}

// The crossing beside `middle` (a traced point whose second singular value is below both its
// neighbours'), along the chords through the three (arc x from `before`): each step draws the V
// of equal slopes through the lowest point and the one beyond it on either side, and evaluates
// its bottom (where that falls on its own side; else a golden-section step into the longer
// side); done where the bottom lies within the tolerance (rad) of the lowest point, or, that
// point's value within the band, is no lower than it.
inline CurvePoint locate_crossing(const Chain& chain, const Frame& target,
                                  const CurvePoint& before, const CurvePoint& middle,
                                  const CurvePoint& after, double tolerance, double lever,
                                  double band) {
  const double d1 = joint_distance(before.q, middle.q), d2 = joint_distance(middle.q, after.q);
  const auto at = [&](double x) {
    const double s = x <= d1 ? x / d1 : 1.0 + (x - d1) / d2;
    return on_chords(chain, target, before.q, middle.q, after.q, s, lever, band, middle.tangent);
  };
  double xl = 0.0, xm = d1, xh = d1 + d2, fl = before.second, fh = after.second;
  CurvePoint lowest = middle;
  for (int iteration = 0; iteration < kCrossingIterations; ++iteration) {
    const double fm = lowest.second;
    const double right_slope = (fh - fm) / (xh - xm), left_slope = (fl - fm) / (xm - xl);
    // the bottom left of the lowest point (the V's right branch through it and the point
    // beyond), or right of it
    const double left_bottom = right_slope > 0.0 ? xm - fm / right_slope : NAN;
    const double right_bottom = left_slope > 0.0 ? xm + fm / left_slope : NAN;
    const bool left_side = left_bottom > xl && left_bottom < xm;
    const bool right_side = right_bottom > xm && right_bottom < xh;
    double x;
    const bool drawn = left_side || right_side;
    if (left_side && right_side) {
      // the V that passes nearer the point on its far branch
      const double left_miss = std::abs(fl - right_slope * (left_bottom - xl));
      const double right_miss = std::abs(fh - left_slope * (xh - right_bottom));
      x = left_miss <= right_miss ? left_bottom : right_bottom;
    } else if (drawn) {
      x = left_side ? left_bottom : right_bottom;
    } else {
      x = xm - xl > xh - xm ? xm - kGolden * (xm - xl) : xm + kGolden * (xh - xm);
    }
    if (std::abs(x - xm) <= tolerance) break;
    const CurvePoint point = at(x);
    // the V's bottom, drawn through points within the band, no lower than the lowest point:
    // the values are the singular value's rounding there
    if (drawn && fm <= band && !(point.second < fm)) break;
    if (point.second < fm) {
      if (x < xm) {
        xh = xm, fh = fm;
      } else {
        xl = xm, fl = fm;
      }
      xm = x, lowest = point;
    } else if (x < xm) {
      xl = x, fl = point.second;
    } else {
      xh = x, fh = point.second;
    }
  }
  return lowest;
}

// The curve of solutions through `root` traced both ways (one way where it closes on itself) by
// steps along its tangent (at most kValleyStep, halved where the point does not verify or
// leaves the curve, down to kValleyStep / 64), each point kept as predicted where it verifies,
// else settled across the curve (and then kept where it moved at most kChordBend of the step);
// the points in order along the curve into `path`, and whether it closed.
inline bool trace_curve(const Chain& chain, const Frame& target, const Joints& root,
                        double tolerance, double lever, double band,
                        std::vector<CurvePoint>& path) {
  const CurvePoint start = curve_point(chain, root, lever, Vector6d::Zero());
  std::vector<CurvePoint> backward;
  for (const double direction : {1.0, -1.0}) {
    std::vector<CurvePoint>& points = direction > 0.0 ? path : backward;
    CurvePoint here = start;
    here.tangent *= direction;
    double step = kValleyStep, travelled = 0.0;
    while (travelled < kValleyLength) {
      Joints predicted, next;
      for (int j = 0; j < kDof; ++j) predicted[j] = here.q[j] + step * here.tangent(j);
      next = predicted;
      // a curve of coincident axes (q_i +- q_j fixed) is a line of joint space: the predicted
      // point verifies as it is, and is settled only where it does not
      bool verified = check(chain, next.data(), target).within(tolerance);
      if (!verified) {
        settle_across(chain, target, next, lever, band);
        verified = check(chain, next.data(), target).within(tolerance) &&
                   joint_distance(next, predicted) <= kChordBend * step;
      }
      const CurvePoint there =
          verified ? curve_point(chain, next, lever, here.tangent) : CurvePoint{};
      if (!verified || !(there.smallest <= tolerance)) {
        step *= 0.5;
        if (step < kValleyStep / 64.0) break;
        continue;
      }
      here = there;
      points.push_back(here);
      travelled += step;
      step = std::min(2.0 * step, kValleyStep);
      if (travelled > kValleyStep && joint_distance(here.q, root) < 0.5 * kValleyStep) {
        path.insert(path.begin(), start);
        return true;
      }
    }
  }
  std::reverse(backward.begin(), backward.end());
  backward.push_back(start);
  path.insert(path.begin(), backward.begin(), backward.end());
  return false;
}

// The crossings of the curves of solutions through `roots` (sigma within the tolerance: every
// point of such a curve verifies) whose target lies off the curve: the root's error above
// Newton's goal (kRefineFraction of the refine tolerance, which a root on its curve reaches;
// off it the error is the same at every member, a floor). Each such curve is traced once (a
// root within a step of a point traced starts none); at each traced point whose second singular
// value lies below both its neighbours' (one of them above the band) the crossing is located,
// and kept where that value is within the band there and it verifies: appended to `roots` (once, where two curves share it)
// flagged `crossing`, so that seed_members neither walks it nor merges it with a member.
inline void crossing_roots(const Chain& chain, const Frame& target, double tolerance,
                           double lever, double band, std::vector<Root>& roots) {
  const double goal = newton::kRefineFraction * refine_tolerance(tolerance, lever);
  std::vector<Joints> visited;
  std::vector<CurvePoint> path;
  const std::size_t found = roots.size();
  for (std::size_t index = 0; index < found; ++index) {
    if (!(roots[index].sigma <= tolerance) || !(roots[index].error.largest() > goal)) continue;
    if (on_traced_valley(roots[index].q, visited)) continue;
    path.clear();
    const bool closed = trace_curve(chain, target, roots[index].q, tolerance, lever, band, path);
    for (const CurvePoint& point : path) visited.push_back(point.q);
    const std::size_t n = path.size();
    if (n < 3) continue;
    for (std::size_t i = closed ? 0 : 1; i < (closed ? n : n - 1); ++i) {
      const CurvePoint& before = path[(i + n - 1) % n];
      const CurvePoint& after = path[(i + 1) % n];
      if (!(path[i].second < before.second && path[i].second <= after.second)) continue;
      // a dip from above the band: along a surface of solutions (the second singular value
      // within the band all along) every point is a member, none a crossing of its own
      if (!(std::max(before.second, after.second) > band)) continue;
      const CurvePoint crossing =
          locate_crossing(chain, target, before, path[i], after, tolerance, lever, band);
      if (!(crossing.second <= band)) continue;
      const PoseError error = check(chain, crossing.q.data(), target);
      if (!error.within(tolerance)) continue;
      // one crossing, located to the tolerance from each curve through it, within the band
      const Joints q = wrapped(crossing.q);
      bool known = false;
      for (std::size_t other = found; other < roots.size() && !known; ++other) {
        known = joint_distance(q, roots[other].q) <= band;
      }
      if (!known) roots.push_back({q, error, crossing.smallest, true});
    }
  }
}

}  // namespace dhkin::general6r
