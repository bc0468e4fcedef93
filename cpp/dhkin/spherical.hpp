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
template <class V>
struct PlanarT {
  V height{}, reach{};
};
using Planar = PlanarT<double>;

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

// angle(target * conj(point)): the turn taking arm-plane `point` towards `target`.
template <class V>
DHKIN_INLINE V turn_to(const PlanarT<V>& target, const PlanarT<V>& point) {
  return atan2(target.reach * point.height - target.height * point.reach,
               target.height * point.height + target.reach * point.reach);
}

// Both q1 branches, with the wrist centre's arm-plane target from axis 2.
template <class V>
struct ShoulderRoots {
  BitsOf<V> flag{}, near{};  // near has kClamped when the centre was moved onto the reach
  MaskOf<V> front_valid{}, back_valid{};
  V front_turn{}, back_turn{};
  V height{}, front_reach{}, back_reach{};
};

// Turning about axis 1 by phi maps the arm-plane point (X, b) to the wrist centre's coordinates
// (x, y) across axis 1: X = +-sqrt(r^2 - b^2), phi = atan2(y, x) - atan2(b, X).
template <class V>
DHKIN_INLINE ShoulderRoots<V> shoulder(const SphericalGeometry& g, const FrameT<V>& T, V seed_q1,
                                 const FamilyRequestT<V>& request, CandidatesT<V>& out) {
  const Vec3T<V> d = T.apply(g.centre_in_flange) - g.origin;
  const V x = dot(d, g.forward), y = dot(d, g.lateral);
  ShoulderRoots<V> roots;
  roots.height = dot(d, g.up);
  const double b = g.lateral_offset;
  const V radius = sqrt(x * x + y * y);
  out.why[0] = radius, out.why[1] = V(std::abs(b));
  const V gap = radius - std::abs(b);
  const auto reachable = gap >= -request.clamp;
  V root = sqrt(max(gap, V(g.spread)) * (radius + std::abs(b)));
  const auto merged = b != 0.0 && small_angle(root, V(std::abs(b)), kMergeAngle);
  root = select(merged, V(0.0), root);
  roots.near = bits_if(b == 0.0 && radius <= request.seed_length, kShoulder);
  const auto seeded = roots.near != 0 && (request.use_seed & kShoulder) != 0;
  roots.near = roots.near | bits_if(gap < 0.0, kClamped);
  const V heading = atan2(y, x);
  const V seeded_turn = g.signs[0] * seed_q1;
  roots.front_turn = select(seeded, seeded_turn, heading - atan2(V(b), root));
  roots.back_turn = select(seeded, seeded_turn + kPi, heading - atan2(V(b), -root));
  roots.flag = bits_if(merged || root <= kFlagBand * g.scale, kShoulder);
  roots.front_valid = reachable;
  roots.back_valid = reachable && !merged;
  roots.front_reach = root - g.shoulder_offset;
  roots.back_reach = -root - g.shoulder_offset;
  return roots;
}

// Columns 0 and 2 of K1 = R1^T R_target M_R^T F Ry(tilt) (R1: the turn by turn1 about `up`).
template <class V>
struct TargetColumns {
  Vec3T<V> first, last;
  SinCosT<V> t1;  // sincos(turn1)
};

template <class V>
DHKIN_INLINE TargetColumns<V> target_columns(const SphericalGeometry& g, const FrameT<V>& T, V turn1) {
  const SinCosT<V> t = sincos(turn1);
  const Vec3T<V> k0 = T.rotate(g.target_to_wrist.column(0));
  const Vec3T<V> k2 = T.rotate(g.target_to_wrist.column(2));
  return {rotate_about(g.up, t.c, -t.s, k0), rotate_about(g.up, t.c, -t.s, k2), t};
}

// Columns 0 and 2 of H = F^T R23^T K1 (below) for an arm turned by turn23 (t23: its sine and
// cosine) about `lateral`.
template <class V>
struct WristColumns {
  Vec3T<V> h0, h2;
};

template <class V>
DHKIN_INLINE WristColumns<V> wrist_columns(const SphericalGeometry& g,
                                           const TargetColumns<V>& columns, const SinCosT<V>& t23) {
  const Vec3T<V> a = rotate_about(g.lateral, t23.c, -t23.s, columns.first);
  const Vec3T<V> b = rotate_about(g.lateral, t23.c, -t23.s, columns.last);
  return {g.wrist_frame.transposed_times(a), g.wrist_frame.transposed_times(b)};
}

// How far one arm branch's turn23 may be off because the arm is only as good as the pose.
template <class V>
struct ArmBand {
  V uncertainty{};      // bound of the move (elbow_uncertainty; 0 where the arm is exact)
  PlanarT<V> target{};  // the wrist centre's arm-plane target from axis 2
  MaskOf<V> flagged{};  // the elbow flagged (or merged): the two elbow branches are one
};

// q4, q5, q6 of both wrist branches.
template <class V>
struct WristRoots {
  V q[2][3] = {};
  V t4[2] = {}, t5[2] = {};  // of each wrist branch: q4 = d4 t4, q5 = d5 (t5 - tilt)
  SinCosT<V> s4[2] = {}, s5[2] = {};  // their sines and cosines
  BitsOf<V> flag{}, near{};
};

// Whether the pose is within the clamp of one at the elbow and the wrist singularity at once:
// the arm at its elbow's singularity (stretched, psi = 0, or folded, psi = pi, whichever length
// is nearer the target's distance) pointed at the target (turn2 as in the closed form) reaches
// it to within the clamp, and there the wrist is singular to within the seed band. Turning the
// arm by delta about `lateral` turns h2 (axis 6 in the wrist frame, wrist columns h of the arm
// turned by turn23) by -delta about F^T lateral. Only at the elbow's singularity: a wrist a hair
// off it whose arm is merely near the stretch (psi ~1e-4) is singular on the other elbow branch
// (or beside axis 2, turning the arm about it); seeding those moved the settled answer onto
// another branch's roots and lost that branch's own (tried, not kept).
template <class V>
DHKIN_INLINE MaskOf<V> wrist_near_at_singular_elbow(const SphericalGeometry& g,
                                                    const WristColumns<V>& h, V turn23,
                                                    const ArmBand<V>& arm,
                                                    const FamilyRequestT<V>& request) {
  const double upper = g.upper_length, fore = g.forearm_length;
  const V distance =
      sqrt(arm.target.height * arm.target.height + arm.target.reach * arm.target.reach);
  const MaskOf<V> folded = abs(distance - std::abs(upper - fore)) < abs(upper + fore - distance);
  const V turn3 = select(folded, V(kPi), V(0.0)) - g.bend_at_zero;
  const SinCosT<V> t3 = sincos(turn3);
  const PlanarT<V> bent{
      g.upper_arm.height + (t3.c * g.forearm.height - t3.s * g.forearm.reach),
      g.upper_arm.reach + (t3.c * g.forearm.reach + t3.s * g.forearm.height)};
  const V length = sqrt(bent.height * bent.height + bent.reach * bent.reach);
  const SinCosT<V> delta = sincos(turn_to(arm.target, bent) + turn3 - turn23);
  const Vec3T<V> h2 = rotate_about(g.wrist_frame.transposed_times(g.lateral), delta.c, -delta.s,
                                   h.h2);
  return abs(length - distance) <= request.clamp &&
         sqrt(h2.x * h2.x + h2.y * h2.y) <= request.seed_angle;
}

// Both wrist branches for each of N arms, arm a turned by turn23[a] about `lateral`:
// H = F^T R23^T K1 = Rz(t4) Ry(t5 + tilt) Rz(t6). The arms go step by step, each step for every
// arm before the next (independent work the processor overlaps); each arm's values are computed
// as they would be for it alone.
//
// Regular: t4 = atan2(h12, h02), then the flip (t4 + pi, -theta, t6 + pi). Seeded (near the
// singularity, `use_seed` has kWrist): the pose fixes only c = t4 + t6 (t4 - t6 where theta is
// near pi); the member of that family nearest the seed in joint space splits the seed's miss
// r = c - (c of the seed), wrapped, evenly between the two joints: t4 = seed's t4 + r / 2 (in both
// branches), theta = +- the computed angle, and t6 from the remainder Ry(-theta) Rz(-t4) H, so
// that the pose error is what the choice costs.
//
// `arms` (per arm): how far turn23 may be off because the arm above is only as good as the pose
// (ArmBand, elbow_uncertainty); the wrist angle inherits it. Beyond the seed band but within it
// by that much more, the wrist counts as near singular where the elbow is flagged, or where the
// pose is within the clamp of one at both singularities (wrist_near_at_singular_elbow).
template <int N, class V>
DHKIN_INLINE void wrists(const SphericalGeometry& g, const TargetColumns<V>* const* columns,
                         const V* turn23, const JointsT<V>& seed,
                         const FamilyRequestT<V>& request, const ArmBand<V> (&arms)[N],
                         WristRoots<V>* roots) {
  const double d4 = g.wrist_directions[0], d5 = g.wrist_directions[1], d6 = g.wrist_directions[2];
  SinCosT<V> t23[N], s_theta[N], s4[N][2];
  V t4[N][2], t5[N][2];  // of each wrist branch
  WristColumns<V> h[N];  // columns 0 and 2 of H
  V sine[N], theta[N], alpha[N];
  MaskOf<V> seeded[N];
  for (int a = 0; a < N; ++a) t23[a] = sincos(turn23[a]);
  for (int a = 0; a < N; ++a) {
    h[a] = wrist_columns(g, *columns[a], t23[a]);
    const V h02 = h[a].h2.x, h12 = h[a].h2.y;
    sine[a] = sqrt(h02 * h02 + h12 * h12);
    roots[a].flag = bits_if(sine[a] <= kFlagBand, kWrist);
    MaskOf<V> near = sine[a] <= request.seed_angle + arms[a].uncertainty;
    // beyond the seed band, the elbow unflagged: near only at both singularities
    const MaskOf<V> widened = near && !arms[a].flagged && sine[a] > request.seed_angle;
    if (any(widened)) {
      near = near && (!widened ||
                      wrist_near_at_singular_elbow(g, h[a], turn23[a], arms[a], request));
    }
    roots[a].near = bits_if(near, kWrist);
    seeded[a] = roots[a].near != 0 && (request.use_seed & kWrist) != 0;
  }
  for (int a = 0; a < N; ++a) {
    theta[a] = atan2(sine[a], h[a].h2.z);
    alpha[a] = atan2(h[a].h2.y, h[a].h2.x);
  }
  for (int a = 0; a < N; ++a) {
    if (!any(seeded[a])) continue;
    // theta near 0 fixes t4 + t6; near pi, t4 - t6 (Ry(pi) Rz(t6) = Rz(-t6) Ry(pi))
    const V h00 = h[a].h0.x, h10 = h[a].h0.y, h20 = h[a].h0.z, h22 = h[a].h2.z;
    const SinCosT<V> ta = sincos(alpha[a]), tt = sincos(theta[a]);
    const V gamma = atan2(-ta.s * h00 + ta.c * h10,
                          tt.c * (ta.c * h00 + ta.s * h10) - tt.s * h20);
    const V turn = select(h22 >= 0.0, V(1.0), V(-1.0));
    alpha[a] = select(seeded[a],
                      d4 * seed[3] + 0.5 * wrap(alpha[a] + turn * gamma - d4 * seed[3] -
                                                turn * d6 * seed[5]),
                      alpha[a]);
  }
  for (int a = 0; a < N; ++a) s_theta[a] = sincos(theta[a]);
  for (int a = 0; a < N; ++a) {
    for (int w = 0; w < 2; ++w) {
      t4[a][w] = alpha[a] + (w == 1 ? select(seeded[a], V(0.0), V(kPi)) : V(0.0));
      t5[a][w] = w == 0 ? theta[a] : -theta[a];
      s4[a][w] = sincos(t4[a][w]);
    }
  }
  for (int a = 0; a < N; ++a) {
    const V h00 = h[a].h0.x, h10 = h[a].h0.y, h20 = h[a].h0.z;
    for (int w = 0; w < 2; ++w) {
      const SinCosT<V> s5 = w == 0 ? s_theta[a] : negated(s_theta[a]);
      const SinCosT<V>& c4 = s4[a][w];
      // Ry(-t5) Rz(-t4) H = Rz(t6): t6 from its first column
      const V t6 =
          atan2(-c4.s * h00 + c4.c * h10, s5.c * (c4.c * h00 + c4.s * h10) - s5.s * h20);
      roots[a].t4[w] = t4[a][w], roots[a].s4[w] = c4;
      roots[a].t5[w] = t5[a][w], roots[a].s5[w] = s5;
      roots[a].q[w][0] = d4 * t4[a][w];
      roots[a].q[w][1] = d5 * (t5[a][w] - g.tilt);
      roots[a].q[w][2] = d6 * t6;
    }
  }
}

// Whether the elbow is flagged: |sin psi| <= kFlagBand, from sine_scaled = 2 L2 L3 sin(psi) (0
// where merged).
template <class V>
DHKIN_INLINE MaskOf<V> elbow_flagged(const SphericalGeometry& g, V sine_scaled) {
  return sine_scaled <= kFlagBand * 2 * g.upper_length * g.forearm_length;
}

// How far turn23 (= turn2 + turn3) may be off for a wrist centre at `distance` from axis 2
// known to +-clamp (m), `sine_scaled` = 2 L2 L3 sin(psi) (0 where the elbow merged). With
// cos(psi) = (distance^2 - L2^2 - L3^2) / (2 L2 L3), the distance moves cos(psi) by at most
// c = distance clamp / (L2 L3), so psi by min(c / |sin psi|, sqrt(2 c)) (the second where the
// arm is stretched or folded: 1 - cos(x) = c); turn2 turns the bent arm (length `distance`)
// onto the target, and a turn of the forearm by x turns it by at most x L3 / distance. Near the
// stretched or folded elbow this is ~sqrt(clamp / L): a pose a hair from both the elbow and the
// wrist singularity has its closed-form q5 that far off (FANUC M-10iA: 5e-6 rad for a pose
// whose q5 is 1e-12; a target 1e-11 m inside the stretch of a pose at both singularities has
// its elbow ~1e-5 rad off, unflagged, and q5 as far). A bound only: unless the elbow is flagged,
// wrists() asks whether the wrist is near singular with the arm at the elbow's singularity
// (wrist_near_at_singular_elbow; counted everywhere, psi ~1e-4 on the anthropomorphic arm
// seeded the other elbow branch's wrists 1e-4 rad off the singularity, whose settling crossed
// to this branch's roots and lost the other's). On a refined table (spread > 0) only where the
// elbow is flagged: its seed band already spans the family band, where the exact chain's
// singular sets lie, and its clamp (with twice the model deviation) makes this bound ~0.1 rad
// (Kinova Gen3), not the tolerance's ~1e-4. Nor where the wrist centre is within the seed band
// of axis 2 (q2 free; the factor L3 / distance unbounded there): seeding the wrist beside q2
// moved the answer off the seed's q2 (anthropomorphic arm folded, tests/test_validate.py).
template <class V>
DHKIN_INLINE V elbow_uncertainty(const SphericalGeometry& g, V distance, V sine_scaled,
                                 double clamp) {
  const double upper = g.upper_length, fore = g.forearm_length;
  const V shift = distance * clamp / (upper * fore);  // of cos(psi)
  const V psi = min(2.0 * upper * fore * shift / max(sine_scaled, V(1e-300)), sqrt(2.0 * shift));
  const V turn = psi * (distance + fore) / max(distance, V(1e-300));
  return g.spread == 0.0 ? turn : select(elbow_flagged(g, sine_scaled), turn, V(0.0));
}

// Both wrist branches for one arm turned by turn23 about `lateral` (wrists above).
template <class V>
DHKIN_INLINE WristRoots<V> wrist(const SphericalGeometry& g, const TargetColumns<V>& columns,
                                 V turn23, const JointsT<V>& seed,
                                 const FamilyRequestT<V>& request) {
  const TargetColumns<V>* arm[1] = {&columns};
  const ArmBand<V> exact[1] = {};  // the arm given, without uncertainty
  WristRoots<V> roots[1];
  wrists<1>(g, arm, &turn23, seed, request, exact, roots);
  return roots[0];
}

template <class V>
DHKIN_INLINE void store(CandidatesT<V>& out, int b, V q1, V q2, V q3, const WristRoots<V>& wrist, int w,
                  MaskOf<V> valid, BitsOf<V> flag, BitsOf<V> near) {
  out.q[b] = {q1, q2, q3, wrist.q[w][0], wrist.q[w][1], wrist.q[w][2]};
  out.valid[b] = valid;
  out.flags[b] = flag;
  out.near[b] = near;
}

}  // namespace spherical

// The 8 branches of the spherical-wrist family for target T (DH frame 0 -> n). Elbow: with psi
// the angle from upper arm to forearm, |target|^2 = L2^2 + L3^2 + 2 L2 L3 cos(psi);
// t3 = psi - psi_0, t2 = arg(target) - arg(upper + exp(i t3) fore).
template <class V>
inline void solve_spherical_wrist(const SphericalGeometry& g, const FrameT<V>& T,
                                  const FamilyRequestT<V>& request, CandidatesT<V>& out) {
  using namespace spherical;
  const JointsT<V>& seed = *request.seed;
  const ShoulderRoots<V> arm = shoulder(g, T, seed[0], request, out);
  const double upper = g.upper_length, fore = g.forearm_length;
  // The branches go step by step, each step for every branch before the next (independent work
  // the processor overlaps): the two shoulder branches s, the four arms k = 2 s + e, their two
  // wrist branches each. Each branch's values are computed as they would be one at a time.
  V turn1[2], cosine_scaled[2], sine_scaled[2];
  PlanarT<V> target[2];
  TargetColumns<V> columns[2];
  MaskOf<V> reachable[2], merged[2], elbow_seeded[2];
  BitsOf<V> clamped[2], elbow_flag[2], elbow_near[2];
  V arm_uncertainty[2];
  for (int s = 0; s < 2; ++s) {
    turn1[s] = s == 0 ? arm.front_turn : arm.back_turn;
    target[s] = {arm.height, s == 0 ? arm.front_reach : arm.back_reach};
    columns[s] = target_columns(g, T, turn1[s]);
    const V distance =
        sqrt(target[s].height * target[s].height + target[s].reach * target[s].reach);
    out.why[2 + s] = distance;
    const V outer = (upper + fore) - distance;
    const V inner = distance - std::abs(upper - fore);
    reachable[s] = outer >= -request.clamp && inner >= -request.clamp;
    clamped[s] = bits_if(outer < 0.0 || inner < 0.0, kClamped);
    // (2 L2 L3 sin psi)^2 as a product of factors: accurate near both boundaries
    sine_scaled[s] = sqrt(max(outer, V(g.spread)) * (upper + fore + distance) *
                          max(inner, V(g.spread)) * (distance + std::abs(upper - fore)));
    cosine_scaled[s] = distance * distance - upper * upper - fore * fore;
    merged[s] = small_angle(sine_scaled[s], abs(cosine_scaled[s]), kMergeAngle);
    sine_scaled[s] = select(merged[s], V(0.0), sine_scaled[s]);
    elbow_flag[s] = bits_if(merged[s] || elbow_flagged(g, sine_scaled[s]), kElbow);
    elbow_near[s] = bits_if(distance <= request.seed_length, kElbow);
    elbow_seeded[s] = elbow_near[s] != 0 && (request.use_seed & kElbow) != 0;
    // not where q2 is free (the centre on axis 2: the elbow's own seeded candidate)
    arm_uncertainty[s] = select(elbow_near[s] != 0, V(0.0),
                                elbow_uncertainty(g, distance, sine_scaled[s], request.clamp));
  }
  V turn2[4], turn3[4], turn23[4];
  SinCosT<V> t3[4];
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2, e = k % 2;
    const V psi = atan2(e == 0 ? sine_scaled[s] : -sine_scaled[s], cosine_scaled[s]);
    turn3[k] = psi - g.bend_at_zero;
  }
  for (int k = 0; k < 4; ++k) t3[k] = sincos(turn3[k]);
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2;
    const PlanarT<V> bent{
        g.upper_arm.height + (t3[k].c * g.forearm.height - t3[k].s * g.forearm.reach),
        g.upper_arm.reach + (t3[k].c * g.forearm.reach + t3[k].s * g.forearm.height)};
    turn2[k] = select(elbow_seeded[s], g.signs[1] * seed[1], turn_to(target[s], bent));
    turn23[k] = turn2[k] + turn3[k];
  }
  const TargetColumns<V>* arm_columns[4] = {&columns[0], &columns[0], &columns[1], &columns[1]};
  WristRoots<V> w[4];
  ArmBand<V> bands[4];
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2;
    bands[k] = {arm_uncertainty[s], target[s], elbow_flag[s] != 0};
  }
  wrists<4>(g, arm_columns, turn23, seed, request, bands, w);
  for (int b = 0; b < kBranches; ++b) {
    const int s = b / 4, e = (b / 2) % 2, k = 2 * s + e, wb = b % 2;
    const auto arm_valid =
        (s == 0 ? arm.front_valid : arm.back_valid) && reachable[s] && (e == 0 || !merged[s]);
    store(out, b, g.signs[0] * turn1[s], g.signs[1] * turn2[k], g.signs[2] * turn3[k], w[k], wb,
          arm_valid, arm.flag | elbow_flag[s] | w[k].flag,
          arm.near | elbow_near[s] | w[k].near | clamped[s]);
    if (out.known != nullptr) {
      out.known->put(b, 0, g.signs[0], turn1[s], columns[s].t1);
      out.known->put(b, 2, g.signs[2], turn3[k], t3[k]);
      out.known->put(b, 3, g.wrist_directions[0], w[k].t4[wb], w[k].s4[wb]);
      // q5 = d5 (t5 - tilt) has the bits of d5 t5 only without a tilt (t5 - 0.0 is t5)
      if (g.tilt == 0.0) out.known->put(b, 4, g.wrist_directions[1], w[k].t5[wb], w[k].s5[wb]);
    }
  }
}

// The 8 branches of the Stanford family (elbow = the slide of joint 3): in the arm plane the
// wrist centre is A + t V turned about axis 2, so |A + t V| = |target| gives
// t = -A.V +- sqrt(|target|^2 - e^2), e the slide line's distance from axis 2.
template <class V>
inline void solve_stanford(const SphericalGeometry& g, const FrameT<V>& T,
                           const FamilyRequestT<V>& request, CandidatesT<V>& out) {
  using namespace spherical;
  const JointsT<V>& seed = *request.seed;
  const ShoulderRoots<V> arm = shoulder(g, T, seed[0], request, out);
  for (int s = 0; s < 2; ++s) {
    const V turn1 = s == 0 ? arm.front_turn : arm.back_turn;
    const PlanarT<V> target{arm.height, s == 0 ? arm.front_reach : arm.back_reach};
    const TargetColumns<V> columns = target_columns(g, T, turn1);
    const V distance = sqrt(target.height * target.height + target.reach * target.reach);
    out.why[2 + s] = distance;
    const V gap = distance - g.slide_offset;
    const auto reachable = gap >= -request.clamp;
    const BitsOf<V> clamped = bits_if(gap < 0.0, kClamped);
    V root = sqrt(max(gap, V(g.spread)) * (distance + g.slide_offset));
    const auto merged = small_angle(root, V(g.slide_offset), kMergeAngle);
    root = select(merged, V(0.0), root);
    const BitsOf<V> slide_flag = bits_if(merged || root <= kFlagBand * g.scale, kElbow);
    for (int e = 0; e < 2; ++e) {
      const V t = -g.slide_along + (e == 0 ? root : -root);
      const PlanarT<V> centre{g.wrist_at_zero.height + t * g.slide.height,
                              g.wrist_at_zero.reach + t * g.slide.reach};
      const auto free = norm_at_most(Vec3T<V>{centre.height, centre.reach, V(0.0)},
                                     request.seed_length);
      const BitsOf<V> slide_near = bits_if(free, kElbow);
      const V turn2 = select(free && (request.use_seed & kElbow) != 0, g.signs[1] * seed[1],
                             turn_to(target, centre));
      const auto arm_valid =
          (s == 0 ? arm.front_valid : arm.back_valid) && reachable && (e == 0 || !merged);
      const WristRoots<V> w = wrist(g, columns, turn2, seed, request);
      for (int k = 0; k < 2; ++k) {
        store(out, 4 * s + 2 * e + k, g.signs[0] * turn1, g.signs[1] * turn2, g.signs[2] * t, w,
              k, arm_valid, arm.flag | slide_flag | w.flag, arm.near | slide_near | w.near | clamped);
      }
    }
  }
}

}  // namespace dhkin
