// Closed-form solvers of the spherical-wrist family (R-R-R arm) and of the Stanford family (R-R-P
// arm), which share the shoulder (axis 1) and the spherical wrist (axes 4, 5, 6).
//
// The geometry comes from dhkin.ik.spherical_wrist and dhkin.ik.stanford, which also document the
// method: everything in DH frame 0, the wrist centre from the target, q1 from the wrist centre's
// position across axis 1 (two shoulder branches), q2 and q3 from a planar problem (law of
// cosines, or the slide), q4..q6 from the remaining rotation as a ZYZ Euler problem (two wrist
// branches). Arm-plane points are complex numbers: height (along axis 1) + i reach.
//
// Reach conditions violated by at most `clamp` (m) are clamped onto the boundary (the pipeline
// verifies the result); two roots within kMergeAngle of each other are one solution (the twin
// branch is invalid). On a refined table (`spread` > 0, the model deviation in metres) roots are
// computed as if the target were at least `spread` inside every reach boundary: where the ideal
// model's two roots merge or vanish, the exact chain's may still be distinct, and the refinement
// finds each from its own side. `why`: wrist centre distance from axis 1, the least it needs, and
// its distance from axis 2 on the front and back branches.
#pragma once

#include <algorithm>
#include <cmath>

#include "dhkin/angles.hpp"
#include "dhkin/bands.hpp"
#include "dhkin/family.hpp"
#include "dhkin/frame.hpp"

namespace dhkin {

// A point of the arm plane: height along axis 1 and reach across it.
struct Planar {
  double height = 0.0, reach = 0.0;
};

struct SphericalGeometry {
  Vec3 centre_in_flange;          // wrist centre in DH frame n
  Vec3 origin;                    // shoulder origin: foot on axis 1 of the common normal to axis 2
  Vec3 forward, lateral, up;      // shoulder frame (up = axis 1)
  double shoulder_offset = 0.0;   // a1: axis 2 from axis 1 along forward
  double lateral_offset = 0.0;    // b: wrist centre along lateral
  double signs[3] = {1, 1, 1};    // turn_i = sign_i * q_i for joints 1-3
  Mat3 wrist_frame;               // F: z along axis 4, y along axis 5
  Mat3 target_to_wrist;           // M_R^T F Ry(tilt)
  double tilt = 0.0;              // axis 6's tilt from axis 4 at q5 = 0
  double wrist_directions[3] = {1, 1, 1};  // directions of joints 4, 5, 6
  double scale = 1.0;             // table length scale (m)
  Planar upper_arm, forearm;      // spherical: axis 3 from axis 2; wrist centre from axis 3
  double upper_length = 0.0, forearm_length = 0.0, bend_at_zero = 0.0;
  Planar wrist_at_zero;           // Stanford: wrist centre at q = 0 from axis 2
  Planar slide;                   // Stanford: unit slide direction in the arm plane
  double slide_along = 0.0, slide_offset = 0.0;  // Stanford: A.V and |e|
  double spread = 0.0;            // m: least distance from a reach boundary roots are computed at
};

namespace spherical {

// Both q1 branches, with the wrist centre's arm-plane target from axis 2.
struct ShoulderRoots {
  std::uint8_t flag = 0, near = 0;  // near has kClamped when the centre was moved onto the reach
  bool front_valid = false, back_valid = false;
  double front_turn = 0.0, back_turn = 0.0;
  double height = 0.0, front_reach = 0.0, back_reach = 0.0;
};

// Turning about axis 1 by phi maps the arm-plane point (X, b) to the wrist centre's coordinates
// (x, y) across axis 1: X = +-sqrt(r^2 - b^2), phi = atan2(y, x) - atan2(b, X).
inline ShoulderRoots shoulder(const SphericalGeometry& g, const Frame& T, double seed_q1,
                              const FamilyRequest& request, Candidates& out) {
  const Vec3 d = T.apply(g.centre_in_flange) - g.origin;
  const double x = dot(d, g.forward), y = dot(d, g.lateral);
  ShoulderRoots roots;
  roots.height = dot(d, g.up);
  const double b = g.lateral_offset;
  const double radius = std::sqrt(x * x + y * y);
  out.why[0] = radius, out.why[1] = std::abs(b);
  const double gap = radius - std::abs(b);
  const bool reachable = gap >= -request.clamp;
  double root = std::sqrt(std::max(gap, g.spread) * (radius + std::abs(b)));
  const bool merged = b != 0.0 && atan2(root, std::abs(b)) <= kMergeAngle;
  if (merged) root = 0.0;
  roots.near = b == 0.0 && radius <= request.seed_length ? kShoulder : 0;
  const bool seeded = roots.near != 0 && (request.use_seed & kShoulder) != 0;
  if (gap < 0.0) roots.near |= kClamped;
  if (seeded) {
    roots.front_turn = g.signs[0] * seed_q1;
    roots.back_turn = roots.front_turn + kPi;
  } else {
    const double heading = atan2(y, x);
    roots.front_turn = heading - atan2(b, root);
    roots.back_turn = heading - atan2(b, -root);
  }
  roots.flag = merged || root <= kFlagBand * g.scale ? kShoulder : 0;
  roots.front_valid = reachable;
  roots.back_valid = reachable && !merged;
  roots.front_reach = root - g.shoulder_offset;
  roots.back_reach = -root - g.shoulder_offset;
  return roots;
}

// Columns 0 and 2 of K1 = R1^T R_target M_R^T F Ry(tilt) (R1: the turn by turn1 about `up`).
struct TargetColumns {
  Vec3 first, last;
};

inline TargetColumns target_columns(const SphericalGeometry& g, const Frame& T, double turn1) {
  const SinCos t = sincos(turn1);
  const Frame& R = T;
  const Vec3 k0 = R.rotate(g.target_to_wrist.column(0));
  const Vec3 k2 = R.rotate(g.target_to_wrist.column(2));
  return {rotate_about(g.up, t.c, -t.s, k0), rotate_about(g.up, t.c, -t.s, k2)};
}

// q4, q5, q6 of both wrist branches.
struct WristRoots {
  double q[2][3] = {};
  std::uint8_t flag = 0, near = 0;
};

// Both wrist branches for an arm turned by turn23 about `lateral`: H = F^T R23^T K1 =
// Rz(t4) Ry(t5 + tilt) Rz(t6).
//
// Regular: t4 = atan2(h12, h02), then the flip (t4 + pi, -theta, t6 + pi). Seeded (near the
// singularity, `use_seed` has kWrist): the pose fixes only c = t4 + t6 (t4 - t6 where theta is
// near pi); the member of that family nearest the seed in joint space splits the seed's miss
// r = c - (c of the seed), wrapped, evenly between the two joints: t4 = seed's t4 + r / 2 (in both
// branches), theta = +- the computed angle, and t6 from the remainder Ry(-theta) Rz(-t4) H, so
// that the pose error is what the choice costs.
inline WristRoots wrist(const SphericalGeometry& g, const TargetColumns& columns, double turn23,
                        const Joints& seed, const FamilyRequest& request) {
  const SinCos t23 = sincos(turn23);
  const Vec3 a = rotate_about(g.lateral, t23.c, -t23.s, columns.first);
  const Vec3 b = rotate_about(g.lateral, t23.c, -t23.s, columns.last);
  const Vec3 h0 = g.wrist_frame.transposed_times(a);  // column 0 of H
  const Vec3 h2 = g.wrist_frame.transposed_times(b);  // column 2 of H
  const double h00 = h0.x, h10 = h0.y, h20 = h0.z, h02 = h2.x, h12 = h2.y, h22 = h2.z;
  const double d4 = g.wrist_directions[0], d5 = g.wrist_directions[1], d6 = g.wrist_directions[2];
  const double sine = std::sqrt(h02 * h02 + h12 * h12);
  WristRoots roots;
  roots.flag = sine <= kFlagBand ? kWrist : 0;
  roots.near = sine <= request.seed_angle ? kWrist : 0;
  const double theta = atan2(sine, h22);
  const bool seeded = roots.near != 0 && (request.use_seed & kWrist) != 0;
  double alpha = atan2(h12, h02);
  if (seeded) {  // theta near 0 fixes t4 + t6; near pi, t4 - t6 (Ry(pi) Rz(t6) = Rz(-t6) Ry(pi))
    const SinCos ta = sincos(alpha), tt = sincos(theta);
    const double gamma = atan2(-ta.s * h00 + ta.c * h10,
                               tt.c * (ta.c * h00 + ta.s * h10) - tt.s * h20);
    const double turn = h22 >= 0.0 ? 1.0 : -1.0;
    alpha = d4 * seed[3] + 0.5 * wrap(alpha + turn * gamma - d4 * seed[3] - turn * d6 * seed[5]);
  }
  for (int w = 0; w < 2; ++w) {
    const double t4 = alpha + (w == 1 && !seeded ? kPi : 0.0);
    const double t5 = w == 0 ? theta : -theta;
    const SinCos s4 = sincos(t4), s5 = sincos(t5);
    // Ry(-t5) Rz(-t4) H = Rz(t6): t6 from its first column
    const double t6 = atan2(-s4.s * h00 + s4.c * h10, s5.c * (s4.c * h00 + s4.s * h10) - s5.s * h20);
    roots.q[w][0] = d4 * t4;
    roots.q[w][1] = d5 * (t5 - g.tilt);
    roots.q[w][2] = d6 * t6;
  }
  return roots;
}

inline void store(Candidates& out, int b, double q1, double q2, double q3, const WristRoots& wrist,
                  int w, bool valid, std::uint8_t flag, std::uint8_t near) {
  out.q[b] = {q1, q2, q3, wrist.q[w][0], wrist.q[w][1], wrist.q[w][2]};
  out.valid[b] = valid;
  out.flags[b] = flag;
  out.near[b] = near;
}

// angle(target * conj(point)): the turn taking arm-plane `point` towards `target`.
inline double turn_to(const Planar& target, const Planar& point) {
  return atan2(target.reach * point.height - target.height * point.reach,
               target.height * point.height + target.reach * point.reach);
}

}  // namespace spherical

// The 8 branches of the spherical-wrist family for target T (DH frame 0 -> n). Elbow: with psi
// the angle from upper arm to forearm, |target|^2 = L2^2 + L3^2 + 2 L2 L3 cos(psi);
// t3 = psi - psi_0, t2 = arg(target) - arg(upper + exp(i t3) fore).
inline void solve_spherical_wrist(const SphericalGeometry& g, const Frame& T,
                                  const FamilyRequest& request, Candidates& out) {
  using namespace spherical;
  const Joints& seed = *request.seed;
  const ShoulderRoots arm = shoulder(g, T, seed[0], request, out);
  const double upper = g.upper_length, fore = g.forearm_length;
  for (int s = 0; s < 2; ++s) {
    const double turn1 = s == 0 ? arm.front_turn : arm.back_turn;
    const Planar target{arm.height, s == 0 ? arm.front_reach : arm.back_reach};
    const TargetColumns columns = target_columns(g, T, turn1);
    const double distance = std::sqrt(target.height * target.height + target.reach * target.reach);
    out.why[2 + s] = distance;
    const double outer = (upper + fore) - distance;
    const double inner = distance - std::abs(upper - fore);
    const bool reachable = outer >= -request.clamp && inner >= -request.clamp;
    const std::uint8_t clamped = outer < 0.0 || inner < 0.0 ? kClamped : 0;
    // (2 L2 L3 sin psi)^2 as a product of factors: accurate near both boundaries
    double sine_scaled = std::sqrt(std::max(outer, g.spread) * (upper + fore + distance) *
                                   std::max(inner, g.spread) * (distance + std::abs(upper - fore)));
    const double cosine_scaled = distance * distance - upper * upper - fore * fore;
    const bool merged = atan2(sine_scaled, std::abs(cosine_scaled)) <= kMergeAngle;
    if (merged) sine_scaled = 0.0;
    const std::uint8_t elbow_flag =
        merged || sine_scaled <= kFlagBand * 2 * upper * fore ? kElbow : 0;
    const std::uint8_t elbow_near = distance <= request.seed_length ? kElbow : 0;
    for (int e = 0; e < 2; ++e) {
      const double psi = atan2(e == 0 ? sine_scaled : -sine_scaled, cosine_scaled);
      const double turn3 = psi - g.bend_at_zero;
      const SinCos t3 = sincos(turn3);
      const Planar bent{g.upper_arm.height + (t3.c * g.forearm.height - t3.s * g.forearm.reach),
                        g.upper_arm.reach + (t3.c * g.forearm.reach + t3.s * g.forearm.height)};
      const double turn2 = elbow_near != 0 && (request.use_seed & kElbow) != 0
                               ? g.signs[1] * seed[1]
                               : turn_to(target, bent);
      const bool arm_valid =
          (s == 0 ? arm.front_valid : arm.back_valid) && reachable && (e == 0 || !merged);
      const WristRoots w = wrist(g, columns, turn2 + turn3, seed, request);
      for (int k = 0; k < 2; ++k) {
        store(out, 4 * s + 2 * e + k, g.signs[0] * turn1, g.signs[1] * turn2,
              g.signs[2] * turn3, w, k, arm_valid, arm.flag | elbow_flag | w.flag,
              arm.near | elbow_near | w.near | clamped);
      }
    }
  }
}

// The 8 branches of the Stanford family (elbow = the slide of joint 3): in the arm plane the
// wrist centre is A + t V turned about axis 2, so |A + t V| = |target| gives
// t = -A.V +- sqrt(|target|^2 - e^2), e the slide line's distance from axis 2.
inline void solve_stanford(const SphericalGeometry& g, const Frame& T,
                           const FamilyRequest& request, Candidates& out) {
  using namespace spherical;
  const Joints& seed = *request.seed;
  const ShoulderRoots arm = shoulder(g, T, seed[0], request, out);
  for (int s = 0; s < 2; ++s) {
    const double turn1 = s == 0 ? arm.front_turn : arm.back_turn;
    const Planar target{arm.height, s == 0 ? arm.front_reach : arm.back_reach};
    const TargetColumns columns = target_columns(g, T, turn1);
    const double distance = std::sqrt(target.height * target.height + target.reach * target.reach);
    out.why[2 + s] = distance;
    const double gap = distance - g.slide_offset;
    const bool reachable = gap >= -request.clamp;
    const std::uint8_t clamped = gap < 0.0 ? kClamped : 0;
    double root = std::sqrt(std::max(gap, g.spread) * (distance + g.slide_offset));
    const bool merged = atan2(root, g.slide_offset) <= kMergeAngle;
    if (merged) root = 0.0;
    const std::uint8_t slide_flag = merged || root <= kFlagBand * g.scale ? kElbow : 0;
    for (int e = 0; e < 2; ++e) {
      const double t = -g.slide_along + (e == 0 ? root : -root);
      const Planar centre{g.wrist_at_zero.height + t * g.slide.height,
                          g.wrist_at_zero.reach + t * g.slide.reach};
      const bool free = std::sqrt(centre.height * centre.height + centre.reach * centre.reach) <=
                        request.seed_length;
      const std::uint8_t slide_near = free ? kElbow : 0;
      const double turn2 = free && (request.use_seed & kElbow) != 0 ? g.signs[1] * seed[1]
                                                                     : turn_to(target, centre);
      const bool arm_valid =
          (s == 0 ? arm.front_valid : arm.back_valid) && reachable && (e == 0 || !merged);
      const WristRoots w = wrist(g, columns, turn2, seed, request);
      for (int k = 0; k < 2; ++k) {
        store(out, 4 * s + 2 * e + k, g.signs[0] * turn1, g.signs[1] * turn2, g.signs[2] * t, w,
              k, arm_valid, arm.flag | slide_flag | w.flag, arm.near | slide_near | w.near | clamped);
      }
    }
  }
}

}  // namespace dhkin
