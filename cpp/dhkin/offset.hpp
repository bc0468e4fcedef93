// Closed-form solver of the offset-wrist family (UR3/UR5/UR10, UR e-series, AUBO i-series,
// Techman).
//
// The geometry and the method are described in dhkin.ik.offset_wrist: product of exponentials in
// DH frame 0; q1 from the wrist point's offset along the common direction n of axes 2-4 (two
// shoulder branches); q5 from n(q1) . z6 = cos(q5 - psi) (two wrist branches); q6 from the rest
// of the orientation; q2, q3, q4 from the planar motion G that remains (two elbow branches).
//
// `near` marks free joints within the seed band: q6 at the wrist singularity, q1 with the wrist
// point on axis 1 (no lateral offset), q2 with axis 4 on axis 2. `why`: the wrist point's distance
// from axis 1, the least it needs (|c|), and the arm span (axis 4 from axis 2) of the four
// shoulder/wrist branches. Near the wrist singularity q6 barely moves the flange's orientation but
// moves axis 4 on a circle about the wrist point: where that puts axis 4 out of the arm's reach,
// q6 is turned the least that brings it onto the reach boundary (`kept_in_reach`); the pipeline
// verifies the result like every solution. Roots near a reach boundary of a refined table: as in
// spherical.hpp (`spread`).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "dhkin/angles.hpp"
#include "dhkin/bands.hpp"
#include "dhkin/brent.hpp"
#include "dhkin/family.hpp"
#include "dhkin/frame.hpp"

namespace dhkin {

struct OffsetGeometry {
  Vec3 directions[6];      // joint axis directions, times each joint's direction
  Vec3 points[6];          // a point on each axis
  Vec3 n;                  // common direction of axes 2-4
  Vec3 side;               // axis 1 x n
  Vec3 plane_x, plane_y;   // angles about n are measured from plane_x towards plane_y
  Vec3 wrist_in_flange;    // the wrist point (axes 5 and 6 meet) in DH frame 6
  Vec3 wrist_point;        // the same at q = 0 in DH frame 0
  Mat3 home_rotation;      // DH frame 6 at q = 0: rotation
  Frame home_inverse;      // its inverse transform
  Vec3 upper_arm, forearm, axis3_x_forearm;
  double lateral = 0.0;    // c: the wrist point's offset along n from axis 1
  double left_sign = 1.0, lateral_sign = 1.0, up_sign = 1.0;
  double psi = 0.0;        // n(q1) . z6 = cos(q5 - psi)
  double sign3 = 1.0, sign4 = 1.0;
  double upper_length = 0.0, forearm_length = 0.0;
  double elbow_alpha = 0.0, elbow_base = 0.0, elbow_turn = 0.0;
  double scale = 1.0;
  double spread = 0.0;     // m: least distance from a reach boundary roots are computed at
};

namespace offset {

// Cosines and sines of -q5, -q6, -q1: the motion G = E1(-q1) T M^-1 E6(-q6) E5(-q5) of joints
// 2-4 (with T_home = T M^-1).
template <class V>
struct TurnsT {
  SinCosT<V> q5, q6, q1;
};
using Turns = TurnsT<double>;

inline Turns lane(const TurnsT<Lanes>& t, int l) {
  return {lane(t.q5, l), lane(t.q6, l), lane(t.q1, l)};
}
inline Turns lane(const Turns& t, int) { return t; }
template <class V>
inline void set_lane(TurnsT<V>& t, int l, const Turns& x) {
  set_lane(t.q5, l, x.q5), set_lane(t.q6, l, x.q6), set_lane(t.q1, l, x.q1);
}

// The rigid motion turning about the line of joint axis `joint` by the angle t, applied to v: a
// point, or a direction.
template <class V, class W>
DHKIN_INLINE Vec3T<Product<V, W>> screw_apply(const OffsetGeometry& g, int joint, const SinCosT<V>& t,
                                        const Vec3T<W>& v, bool point) {
  const Vec3& axis = g.directions[joint];
  if (!point) return rotate_about(axis, t.c, t.s, v);
  const Vec3& p = g.points[joint];
  return rotate_about(axis, t.c, t.s, v - p) + p;
}

// G v (a point or a direction).
template <class V>
DHKIN_INLINE Vec3T<V> motion_apply(const OffsetGeometry& g, const FrameT<V>& T_home,
                             const TurnsT<V>& turns, const Vec3& v, bool point) {
  Vec3T<V> x = screw_apply(g, 4, turns.q5, v, point);
  x = screw_apply(g, 5, turns.q6, x, point);
  const Vec3T<V> y = point ? T_home.apply(x) : T_home.rotate(x);
  return screw_apply(g, 0, turns.q1, y, point);
}

// Component of v normal to n.
template <class V>
DHKIN_INLINE Vec3T<V> in_plane(const OffsetGeometry& g, const Vec3T<V>& v) {
  return v - dot(v, g.n) * g.n;
}

// The arm's target: axis 4's point under G, from axis 2's point, normal to n.
template <class V>
DHKIN_INLINE Vec3T<V> arm_point(const OffsetGeometry& g, const FrameT<V>& T_home,
                          const TurnsT<V>& turns) {
  return in_plane(g, motion_apply(g, T_home, turns, g.points[3], true) - g.points[1]);
}

// Angle about n of v from plane_x.
template <class V>
DHKIN_INLINE V plane_angle(const OffsetGeometry& g, const Vec3T<V>& v) {
  return atan2(dot(v, g.plane_y), dot(v, g.plane_x));
}

// q6, turned the least that brings axis 4 onto the arm's reach boundary when it lies out of
// reach by more than `clamp`; q6 itself otherwise (or when no turn reaches it). One lane.
inline double kept_in_reach(const OffsetGeometry& g, const Frame& T_home, const Turns& turns,
                            const Vec3& arm, double q5, double q6, double clamp) {
  const double low = std::abs(g.upper_length - g.forearm_length);
  const double high = g.upper_length + g.forearm_length;
  const double span = norm(arm);
  const bool too_far = span > high + clamp;
  const bool too_near = span < low - clamp;
  if (!(too_far || too_near)) return q6;
  const Vec3 centre = in_plane(g, motion_apply(g, T_home, turns, g.wrist_point, true) -
                                      g.points[1]);
  const double boundary = too_far ? high : low;
  const Vec3 d = arm - centre;
  const double radius = norm(d);
  const double distance = norm(centre);
  const double denominator = 2.0 * distance * radius;
  if (!(denominator > 0.0)) return q6;
  double cos_needed = (boundary * boundary - distance * distance - radius * radius) / denominator;
  if (!(std::abs(cos_needed) <= 1.0)) {
    // tangent reach (stretched or folded arm): rounding may put |cos| a hair above 1
    if (std::abs(cos_needed) - 1.0 > clamp / std::max(distance, radius)) return q6;
    cos_needed = std::min(std::max(cos_needed, -1.0), 1.0);
  }
  const double opening = std::acos(cos_needed);
  const double now = plane_angle(g, d) - plane_angle(g, centre);
  const double first = wrap(opening - now), second = wrap(-opening - now);
  const double turn = std::abs(first) <= std::abs(second) ? first : second;
  const SinCos t5 = sincos(q5);
  const Vec3 axis6 = motion_apply(g, T_home, turns,
                                  rotate_about(g.directions[4], t5.c, t5.s, g.directions[5]),
                                  false);
  // axis 6 is nearly +-n here: turning q6 by delta turns axis 4 about n by -sign * delta
  return q6 - (dot(axis6, g.n) >= 0.0 ? 1.0 : -1.0) * turn;
}

// q2, q3, q4 of one elbow branch, with its validity, flag and near bits.
template <class V>
struct ElbowRoot {
  V q2{}, q3{}, q4{};
  SinCosT<V> t3{};  // sincos(q3)
  MaskOf<V> valid{};
  BitsOf<V> flag{}, near{};
};

// What both elbow branches of one motion G share: the law of cosines (q3 of each branch, in
// branch order), the reach test and flags, and G's angle about n.
template <class V>
struct ElbowSetup {
  V q3[2] = {};
  SinCosT<V> t3[2] = {};  // sincos(q3[e])
  MaskOf<V> reach_ok{}, merged{}, clamped{};
  BitsOf<V> flag{};
  V total{};  // angle about n of G plane_x from plane_x
};

// The elbow setups of N motions G (turns[a], span[a] = |arm|), step by step, each step for every
// motion before the next (independent work the processor overlaps); each one's values are
// computed as they would be for it alone. `reach_side`: doubles, or per lane (the branches of one
// pose in lanes, branch_lanes.hpp).
template <int N, class V, class R>
DHKIN_INLINE void elbow_setups(const OffsetGeometry& g, const FrameT<V>& T_home,
                               const TurnsT<V>* turns, const V* span, const R* reach_side,
                               double clamp, ElbowSetup<V>* out) {
  const double L2 = g.upper_length, L3 = g.forearm_length;
  const double low = std::abs(L2 - L3), high = L2 + L3;
  V root[N], kappa[N], first[N], second[N];
  SinCosT<V> f[N], f2[N];
  for (int a = 0; a < N; ++a) {
    out[a].total = plane_angle(g, motion_apply(g, T_home, turns[a], g.plane_x, false));
  }
  for (int a = 0; a < N; ++a) {
    const V outer = high - span[a], inner = span[a] - low;
    out[a].reach_ok = outer >= -clamp && inner >= -clamp;
    out[a].clamped = outer < 0.0 || inner < 0.0;
    // (L2 L3)^2 - kappa^2 in factored form: accurate near both boundaries
    root[a] = sqrt(max(outer, V(g.spread)) * (high + span[a]) * max(inner, V(g.spread)) *
                   (span[a] + low)) / 2.0;
    kappa[a] = (span[a] * span[a] - L2 * L2 - L3 * L3) / 2.0;
  }
  for (int a = 0; a < N; ++a) {
    out[a].merged = small_angle(root[a], abs(kappa[a]), kMergeAngle);
    root[a] = select(out[a].merged, V(0.0), root[a]);
    out[a].flag = bits_if(out[a].merged || root[a] <= kFlagBand * L2 * L3, kElbow);
  }
  for (int a = 0; a < N; ++a) {
    const V half = atan2(root[a], kappa[a]);
    first[a] = g.elbow_base + half, second[a] = g.elbow_base - half;
  }
  for (int a = 0; a < N; ++a) f[a] = sincos(first[a]);
  for (int a = 0; a < N; ++a) f2[a] = sincos(second[a]);  // both roots' for the elbows
  for (int a = 0; a < N; ++a) {
    const V turn = f[a].c * g.elbow_turn + g.sign3 * f[a].s * g.elbow_alpha;
    const auto swap = select(turn >= 0.0, V(1.0), V(-1.0)) != V(reach_side[a]);
    out[a].q3[0] = select(swap, second[a], first[a]);
    out[a].q3[1] = select(swap, first[a], second[a]);
    out[a].t3[0] = {select(swap, f2[a].s, f[a].s), select(swap, f2[a].c, f[a].c)};
    out[a].t3[1] = {select(swap, f[a].s, f2[a].s), select(swap, f[a].c, f2[a].c)};
  }
}

// What both elbow branches of one motion G share (elbow_setups above).
template <class V, class R>
DHKIN_INLINE ElbowSetup<V> elbow_setup(const OffsetGeometry& g, const FrameT<V>& T_home,
                                       const TurnsT<V>& turns, V span, R reach_side,
                                       double clamp) {
  ElbowSetup<V> out[1];
  elbow_setups<1>(g, T_home, &turns, &span, &reach_side, clamp, out);
  return out[0];
}

// The same, for the arm's target point (span = |arm|).
template <class V>
DHKIN_INLINE ElbowSetup<V> elbow_setup(const OffsetGeometry& g, const FrameT<V>& T_home,
                                       const TurnsT<V>& turns, const Vec3T<V>& arm,
                                       double reach_side, double clamp) {
  return elbow_setup(g, T_home, turns, norm(arm), reach_side, clamp);
}

// Elbow branch e: the planar rotation taking the bent arm onto the target for q2, the angle of G
// about n for q4.
template <class V>
DHKIN_INLINE ElbowRoot<V> elbow(const OffsetGeometry& g, const ElbowSetup<V>& setup,
                          const Vec3T<V>& arm, V seed_q2, const FamilyRequestT<V>& request,
                          int e) {
  ElbowRoot<V> out;
  out.flag = setup.flag;
  out.q3 = setup.q3[e];
  const SinCosT<V> t3 = setup.t3[e];  // sincos(out.q3)
  out.t3 = t3;
  const Vec3T<V> bent = g.upper_arm + t3.c * g.forearm + t3.s * g.axis3_x_forearm;
  out.near = bits_if(norm_at_most(bent, request.seed_length), kElbow);
  const auto seeded = out.near != 0 && (request.use_seed & kElbow) != 0;
  out.near = out.near | bits_if(setup.clamped, kClamped);
  out.q2 = select(seeded, seed_q2, atan2(dot(g.n, cross(bent, arm)), dot(bent, arm)));
  out.q4 = g.sign4 * (setup.total - out.q2 - g.sign3 * out.q3);
  out.valid = setup.reach_ok && (e == 0 || !setup.merged);
  return out;
}

// One member of the solution family at the wrist singularity, with q6 = t (moved onto the arm's
// reach if needed).
struct Member {
  double q2 = 0.0, q3 = 0.0, q4 = 0.0, q6 = 0.0;
  bool valid = false;
  double distance = 0.0;  // squared joint distance to the seed over joints 2-4 and 6 (wrapped)
  std::uint8_t flag = 0;  // its kElbow flag
};

// A member's squared joint distance from the seed over joints 2-4 and 6 (wrapped): q2-q4 of its
// elbow root, q6 = t (member() for one point, member_grid() for kLanes points).
template <class V>
DHKIN_INLINE V member_distance(const ElbowRoot<V>& root, V t, const Joints& seed) {
  const V a = wrap(root.q2 - seed[1]), b = wrap(root.q3 - seed[2]), c = wrap(root.q4 - seed[3]),
          d = wrap(t - seed[5]);
  return a * a + b * b + c * c + d * d;
}

inline Member member(const OffsetGeometry& g, const Frame& T_home, const SinCos& t1, double q5,
                     double t, double reach_side, const Joints& seed, const FamilyRequest& request,
                     int e) {
  const SinCos t5 = sincos(-q5);
  Turns turns{t5, sincos(-t), t1};
  Vec3 arm = arm_point(g, T_home, turns);
  const double kept = kept_in_reach(g, T_home, turns, arm, q5, t, request.clamp);
  if (kept != t) {
    t = kept;
    turns.q6 = sincos(-t);
    arm = arm_point(g, T_home, turns);
  }
  const ElbowSetup<double> setup = elbow_setup(g, T_home, turns, arm, reach_side, request.clamp);
  const ElbowRoot<double> root = elbow(g, setup, arm, seed[1], request, e);
  Member out;
  out.q2 = root.q2, out.q3 = root.q3, out.q4 = root.q4, out.q6 = t;
  out.distance = member_distance(root, t, seed);
  out.valid = root.valid && std::isfinite(out.distance);
  out.flag = root.flag;
  return out;
}
// Nearest-member search over q6: a grid of this half-width and step (rad) around the seed's q6
// (where q6 would leave axis 4 out of reach it is moved onto the reach boundary, so far members
// are found at the grid's edge), then Brent's search to kMemberPrecision within a step of the
// best grid point. The distance is not smooth (square roots near a stretched or folded elbow,
// the move onto the boundary): no derivatives are used.
constexpr double kMemberHalfWidth = kPi;
constexpr double kMemberStep = 0.05;
constexpr double kMemberPrecision = 1e-9;
// Grid points on each side of the seed's q6 (the whole turn: q2-q4 follow q6, so the nearest
// member can be far from the seed's q6).
constexpr int kMemberGrid = 63;  // ceil(kMemberHalfWidth / kMemberStep)
static_assert(kMemberGrid * kMemberStep >= kMemberHalfWidth &&
                  (kMemberGrid - 1) * kMemberStep < kMemberHalfWidth,
              "kMemberGrid = ceil(kMemberHalfWidth / kMemberStep)");

// The grid's points, in blocks of kLanes (the last block's spare lanes are not read).
constexpr int kMemberPoints = 2 * kMemberGrid + 1;
constexpr int kMemberBlocks = (kMemberPoints + kLanes - 1) / kLanes;

// member()'s distance at each point of the nearest-member grid, for both elbow branches (infinity
// where the branch has no member): grid point i is t = seed[5] + (i - kMemberGrid) kMemberStep.
struct MemberGrid {
  alignas(64) double distance[2][kMemberBlocks * kLanes];
};

// The grid of nearest_member with kLanes points at a time, both elbow branches from one setup:
// each lane's distance is member()'s for its point, bit for bit (the same operations per lane;
// a point whose axis 4 lies out of reach is moved onto it by kept_in_reach, lane by lane).
inline void member_grid(const OffsetGeometry& g, const Frame& T_home, const SinCos& t1, double q5,
                        double reach_side, const Joints& seed, const FamilyRequest& request,
                        MemberGrid& grid) {
  const FrameT<Lanes> home = broadcast<Lanes>(T_home);
  const SinCos t5 = sincos(-q5);
  JointsT<Lanes> seeds;
  for (int j = 0; j < kDof; ++j) seeds[j] = Lanes(seed[j]);
  const FamilyRequestT<Lanes> requests{&seeds,         request.use_seed,    request.seed_angle,
                                       request.seed_length, request.clamp, request.only_branch,
                                       request.at_seed};
  const double low = std::abs(g.upper_length - g.forearm_length);
  const double high = g.upper_length + g.forearm_length;
  alignas(64) double points[kLanes];
  for (int block = 0; block < kMemberBlocks; ++block) {
    for (int l = 0; l < kLanes; ++l) {
      points[l] = seed[5] + (block * kLanes + l - kMemberGrid) * kMemberStep;
    }
    Lanes t = Lanes::load(points);
    TurnsT<Lanes> turns{{Lanes(t5.s), Lanes(t5.c)}, sincos(-t), {Lanes(t1.s), Lanes(t1.c)}};
    Vec3T<Lanes> arm = arm_point(g, home, turns);
    // kept_in_reach's own test: only these lanes may move
    const Lanes span = norm(arm);
    for_each_lane(span > high + request.clamp || span < low - request.clamp, [&](int l) {
      Turns turns_l = lane(turns, l);
      const double t_l = lane(t, l);
      const double kept = kept_in_reach(g, T_home, turns_l, lane(arm, l), q5, t_l, request.clamp);
      if (kept != t_l) {
        turns_l.q6 = sincos(-kept);
        set_lane(t, l, kept);
        set_lane(turns, l, turns_l);
        set_lane(arm, l, arm_point(g, T_home, turns_l));
      }
    });
    const ElbowSetup<Lanes> setup = elbow_setup(g, home, turns, arm, reach_side, request.clamp);
    for (int e = 0; e < 2; ++e) {
      const ElbowRoot<Lanes> root = elbow(g, setup, arm, seeds[1], requests, e);
      const Lanes distance = member_distance(root, t, seed);
      const Mask valid = root.valid && abs(distance) < INFINITY;
      select(valid, distance, Lanes(INFINITY)).store(grid.distance[e] + block * kLanes);
    }
  }
}

// At the wrist singularity the pose leaves a one-parameter family (q6 free, q2, q3, q4 following
// it): the member nearest the seed in joint space (squared distance over joints 2-4 and 6),
// searched over q6 (the grid's distances from member_grid). False when no member of this elbow
// branch exists near the seed.
inline bool nearest_member(const OffsetGeometry& g, const Frame& T_home, const SinCos& t1,
                           double q5, double reach_side, const Joints& seed,
                           const FamilyRequest& request, int e, const MemberGrid& grid,
                           Member& found) {
  double best_t = seed[5], best = std::numeric_limits<double>::infinity();
  for (int k = -kMemberGrid; k <= kMemberGrid; ++k) {
    const double t = seed[5] + k * kMemberStep;
    const double distance = grid.distance[e][k + kMemberGrid];
    if (distance < best) best_t = t, best = distance;
  }
  if (best == std::numeric_limits<double>::infinity()) return false;
  // the member of the point Brent's search keeps as its best (a score at or below the best so
  // far, its own rule), so that the point it returns need not be evaluated again
  double kept_t = NAN, kept_score = best;
  const auto value = [&](double t) {
    const Member m = member(g, T_home, t1, q5, t, reach_side, seed, request, e);
    const double score = m.valid ? m.distance : std::numeric_limits<double>::infinity();
    if (score <= kept_score) kept_t = t, kept_score = score, found = m;
    return score;
  };
  // the best point scored, never worse than the grid's
  const double nearest = brent_minimum(best_t - kMemberStep, best_t + kMemberStep,
                                       kMemberPrecision, best_t, best, value);
  if (!(kept_t == nearest)) {  // the grid's point (scored in lanes, not here)
    found = member(g, T_home, t1, q5, nearest, reach_side, seed, request, e);
  }
  return true;
}

}  // namespace offset

// The 8 branches of the offset-wrist family for target T, DH frame 0 -> 6.
template <class V>
inline void solve_offset_wrist(const OffsetGeometry& g, const FrameT<V>& T,
                               const FamilyRequestT<V>& request, CandidatesT<V>& out) {
  using namespace offset;
  const JointsT<V>& seed = *request.seed;
  const FrameT<V> T_home = T * g.home_inverse;
  // q1: both roots of n(q1) . (wrist point - r1) = c
  const Vec3T<V> h = T.apply(g.wrist_in_flange) - g.points[0];
  const V along_n = dot(h, g.n), along_side = dot(h, g.side);
  const V distance = sqrt(along_n * along_n + along_side * along_side);
  const double c = g.lateral;
  out.why[0] = distance, out.why[1] = V(std::abs(c));
  const V gap = distance - std::abs(c);
  const auto shoulder_ok = gap >= -request.clamp;
  V root = sqrt(max(gap, V(g.spread)) * (distance + std::abs(c)));
  const auto shoulder_merged = c != 0.0 && small_angle(root, V(std::abs(c)), kMergeAngle);
  root = select(shoulder_merged, V(0.0), root);
  const BitsOf<V> shoulder_flag =
      bits_if(shoulder_merged || root <= kFlagBand * g.scale, kShoulder);
  // Near the shoulder merge q1 is only as good as the pose over the root: a pose known to `clamp`
  // moves it by ~clamp / root (at most ~sqrt(2 clamp / |c|)), and q5 inherits that: the wrist
  // counts as near singular within this much more.
  V q1_uncertainty(0.0);
  if (c != 0.0) {
    q1_uncertainty = min(request.clamp / max(root, V(1e-300)),
                         V(std::sqrt(2.0 * request.clamp / std::abs(c))));
  }
  BitsOf<V> shoulder_near = bits_if(c == 0.0 && distance <= request.seed_length, kShoulder);
  const auto shoulder_seeded = shoulder_near != 0 && (request.use_seed & kShoulder) != 0;
  shoulder_near = shoulder_near | bits_if(gap < 0.0, kClamped);
  const V phase = atan2(along_side, along_n);
  const V half = atan2(root, V(c));
  const Vec3& w6 = g.directions[5];
  // The branches go step by step, each step for every branch before the next (independent work
  // the processor overlaps; a branch's steps form one long chain of dependent operations): the
  // two shoulder branches s, the four shoulder-wrist branches k = 2 s + w, the eight branches
  // b = 4 s + 2 e + w. Each branch's values are computed as they would be one branch at a time.
  V q1[2], cosine[2], sine[2], q5_half[2];
  MaskOf<V> q1_valid[2], wrist_close[2], wrist_seeded[2];
  BitsOf<V> wrist_flag[2], wrist_near[2];
  SinCosT<V> t1[2];
  Vec3T<V> u[2];
  for (int s = 0; s < 2; ++s) {
    q1[s] = select(shoulder_seeded, seed[0] + (s == 0 ? 0.0 : kPi),
                   s == 0 ? phase + g.left_sign * half : phase - g.left_sign * half);
    q1_valid[s] = shoulder_ok && (s == 0 || !shoulder_merged);
  }
  // q5 from n(q1) . z6 = cos(q5 - psi), q6 from the rest
  for (int s = 0; s < 2; ++s) t1[s] = sincos(q1[s]);
  for (int s = 0; s < 2; ++s) {
    const Vec3T<V> m = rotate_about(g.directions[0], t1[s].c, t1[s].s, g.n);
    const Vec3T<V> f{T.R[0][0] * m.x + T.R[1][0] * m.y + T.R[2][0] * m.z,  // R_T^T n(q1)
                     T.R[0][1] * m.x + T.R[1][1] * m.y + T.R[2][1] * m.z,
                     T.R[0][2] * m.x + T.R[1][2] * m.y + T.R[2][2] * m.z};
    u[s] = g.home_rotation * f;  // u = M_R R_T^T n(q1)
    cosine[s] = dot(u[s], w6);
    sine[s] = norm(cross(w6, u[s]));  // exact for tiny angles (no arccos)
    wrist_flag[s] = bits_if(sine[s] <= kFlagBand, kWrist);
    wrist_close[s] = sine[s] <= request.seed_angle + q1_uncertainty;
    wrist_near[s] = bits_if(wrist_close[s], kWrist);
    wrist_seeded[s] = wrist_close[s] && (request.use_seed & kWrist) != 0;
  }
  for (int s = 0; s < 2; ++s) q5_half[s] = atan2(sine[s], cosine[s]);
  V q5[4], q6[4], span[4];
  SinCosT<V> minus_q5[4];
  TurnsT<V> turns[4];
  Vec3T<V> arm[4];
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2, w = k % 2;
    q5[k] = g.psi + (w == 0 ? g.up_sign * q5_half[s] : -g.up_sign * q5_half[s]);
  }
  for (int k = 0; k < 4; ++k) minus_q5[k] = sincos(-q5[k]);
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2;
    const Vec3T<V> a = u[s] - cosine[s] * w6;
    const Vec3T<V> t = rotate_about(g.directions[4], minus_q5[k].c, minus_q5[k].s, g.n);  // R5^T n
    const Vec3T<V> b = t - dot(t, w6) * w6;
    q6[k] = select(wrist_seeded[s], seed[5], atan2(dot(w6, cross(a, b)), dot(a, b)));
  }
  for (int k = 0; k < 4; ++k) {
    turns[k] = {minus_q5[k], sincos(-q6[k]), negated(t1[k / 2])};  // negated: sincos(-q1)
  }
  for (int k = 0; k < 4; ++k) arm[k] = arm_point(g, T_home, turns[k]);
  for (int k = 0; k < 4; ++k) {
    for_each_lane(wrist_close[k / 2], [&](int l) {  // near the wrist singularity: q6 kept in reach
      Turns turns_l = lane(turns[k], l);
      const double q6_l = lane(q6[k], l);
      const double kept = kept_in_reach(g, lane(T_home, l), turns_l, lane(arm[k], l),
                                        lane(q5[k], l), q6_l, request.clamp);
      if (kept != q6_l) {
        turns_l.q6 = sincos(-kept);
        set_lane(q6[k], l, kept);
        set_lane(turns[k], l, turns_l);
        set_lane(arm[k], l, arm_point(g, lane(T_home, l), turns_l));
      }
    });
  }
  for (int k = 0; k < 4; ++k) {
    span[k] = norm(arm[k]);
    out.why[2 + k] = span[k];
  }
  ElbowSetup<V> setup[4];
  const double reach_side[4] = {g.lateral_sign, g.lateral_sign, -g.lateral_sign, -g.lateral_sign};
  elbow_setups<4>(g, T_home, turns, span, reach_side, request.clamp, setup);
  ElbowRoot<V> roots[kBranches];
  for (int b = 0; b < kBranches; ++b) {
    const int k = 2 * (b / 4) + b % 2, e = (b / 2) % 2;
    roots[b] = elbow(g, setup[k], arm[k], seed[1], request, e);
  }
  for (int b = 0; b < kBranches; ++b) {
    const int s = b / 4, w = b % 2, k = 2 * s + w;
    const ElbowRoot<V>& r = roots[b];
    // the two wrist roots coincide exactly: one solution
    const auto wrist_valid = w == 0 || wrist_seeded[s] || sine[s] != 0.0;
    out.q[b] = {q1[s], r.q2, r.q3, r.q4, q5[k], q6[k]};
    out.valid[b] = q1_valid[s] && wrist_valid && r.valid;
    out.flags[b] = shoulder_flag | wrist_flag[s] | r.flag;
    out.near[b] = shoulder_near | wrist_near[s] | r.near;
    if (out.known != nullptr) {  // sincos(-x) negated: the bits of sincos(x)
      out.known->put(b, 0, 1.0, q1[s], t1[s]);
      out.known->put(b, 2, 1.0, r.q3, r.t3);
      out.known->put(b, 4, 1.0, q5[k], negated(minus_q5[k]));
      out.known->put(b, 5, 1.0, q6[k], negated(turns[k].q6));
    }
  }
  for (int k = 0; k < 4; ++k) {
    const int s = k / 2, w = k % 2;
    const double reach_side = s == 0 ? g.lateral_sign : -g.lateral_sign;
    const SinCosT<V> minus_q1 = turns[k].q1;
    for_each_lane(wrist_seeded[s] && q1_valid[s], [&](int l) {  // the member nearest the seed
      Joints seed_l;
      const FamilyRequest request_l = lane(request, l, seed_l);
      const Frame home = lane(T_home, l);
      const SinCos minus_q1_l = lane(minus_q1, l);
      const double q5_l = lane(q5[k], l);
      MemberGrid grid;
      bool gridded = false;
      for (int e = 0; e < 2; ++e) {
        const int b = 4 * s + 2 * e + w;
        if (request.only_branch >= 0 && b != request.only_branch) {
          set_lane(out.valid[b], l, false);
          continue;
        }
        Member found;
        bool located;
        if (request.at_seed) {
          found = member(g, home, minus_q1_l, q5_l, seed_l[5], reach_side, seed_l, request_l, e);
          located = found.valid;
        } else {
          if (!gridded) {
            member_grid(g, home, minus_q1_l, q5_l, reach_side, seed_l, request_l, grid);
            gridded = true;
          }
          located = nearest_member(g, home, minus_q1_l, q5_l, reach_side, seed_l, request_l, e,
                                   grid, found);
        }
        if (located) {
          set_lane(out.q[b][1], l, found.q2);
          set_lane(out.q[b][2], l, found.q3);
          set_lane(out.q[b][3], l, found.q4);
          set_lane(out.q[b][5], l, found.q6);
          set_lane(out.valid[b], l, true);
          set_lane(out.flags[b], l, (lane(out.flags[b], l) & ~kElbow) | found.flag);
        }
      }
    });
  }
  out.drop_non_finite();
}

}  // namespace dhkin
