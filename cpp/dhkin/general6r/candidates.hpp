// The general 6R solver's starts for one pose: the elimination's eigenvalues, split into one
// monomial vector per root, back-substituted (docs/general6r.md, "How it works", steps 3-5).
//
// M(x) = A x^2 + B x + C (12 x 12), theta_k = lead + 2 atan(x). Its leading matrix A = M at
// theta_k = lead + pi must be invertible: of the four angles shift + {0, 1, 2, 3} pi/2 the first
// whose matrix is conditioned within kCompanionCondition becomes lead (else the best of them), so
// that no root lies at infinity unless all four are roots. The eigenvalues come from the
// companion matrix [[0, I], [-A^-1 C, -A^-1 B]] (24 x 24, eigenvalues.hpp; its eight spurious
// eigenvalues +-i deflated, deflation.hpp) where A is conditioned within kCompanionCondition,
// else from QZ on the 24 x 24 pencil (Eigen's real QZ: backward stable, it keeps the eigenvalues
// of the regular part, and A^-1 does not amplify its rounding). Where no leading matrix is
// conditioned within kLeadCondition, or a cluster holds more than kMaxSplit eigenvalues, the pose
// is solved moved as well (all_candidates), by QZ.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <vector>

#include "dhkin/general6r/back_substitution.hpp"
#include "dhkin/general6r/eigenvalues.hpp"
#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/null_space.hpp"
#include "dhkin/general6r/right_side.hpp"

namespace dhkin::general6r {

// A pose whose best leading matrix is conditioned (reciprocal condition, 1-norm) below this has an
// ill-conditioned eigenproblem: its eigenvalues lose ~1e-8 relative to rounding, and it is solved
// moved as well (all_candidates).
constexpr double kLeadCondition = 1e-8;
// The companion (deflated where the arm has the spurious eigenvalues +-i, deflation.hpp) is used
// only where its leading matrix is conditioned within this, three orders better than
// kLeadCondition; elsewhere QZ on the pencil. The companion's rounding is amplified by A^-1: on
// 500-1,000 random poses per arm its largest eigenvalue errors were 1.6e-7 .. 5.2e-6 with the
// first lead's condition within 1e-8 .. 1e-5 and at most 1.2e-7 above (docs/general6r.md, "Speed,
// seventh pass"), and at an HC10 pose whose four leading matrices are all conditioned at 1e-8 ..
// 3e-8 (four nearly double eigenvalues, roots 3e-5 .. 9e-5 rad apart) the copies of a double
// eigenvalue fell 2.0e-3 and 3.6e-3 apart in the AVX-512 build (2.4e-3 deflated in the AVX2
// one), beyond kCluster: two roots were lost. QZ's eigenvalues there are the roots' to within
// kCluster, and all eight come back. Such poses are rare (~0.1 % of random poses of the
// CRX-10iA and the HC10, none of the xArm6's; 1.7 % of the special-angle ones' eliminations),
// so the QZ's cost is not felt.
constexpr double kCompanionCondition = 1e3 * kLeadCondition;
// Eigenvalues of the eliminated joint whose angles (rad, real parts) lie closer than this are
// one cluster, split at each member into as many starts as the cluster has members. Taking two
// eigenvalues together costs starts, never roots (each member's own null vector is in its
// split); taking apart the copies of an eigenvalue shared by two roots loses one. Rounding
// spreads such copies by ~eps / (the leading matrix's condition) ~2e-8 at kLeadCondition (a
// defective double eigenvalue, a fold, by ~its square root, 1.5e-4). Each member is split at its
// own value, not at the cluster's mean: two roots whose eliminated joints differ by 1e-7 rad and
// whose monomial vectors are nearly parallel (a CRX-10iA pose near q5 = 0) are exact at their
// own members, mixed at the mean.
constexpr double kCluster = 1e-3;
// Beyond this size an eigenvalue is infinite (theta_k = lead + pi to the last bit).
constexpr double kInfinite = 1e150;

// Where a start comes from (bits): a near-real complex pair of eigenvalues (its imaginary angle
// beyond kCluster, within the band); a cluster of eigenvalues (its root's fold partner is
// probed); the pose's own eigenproblem where it is ill-conditioned (all_candidates: refined as a
// pair's start); moved pose p (kMoved << p: its root is followed back to the pose).
enum Origin : std::uint32_t { kPaired = 1, kShared = 2, kIll = 4, kMoved = 8 };

struct Start {
  Joints q{};
  std::uint32_t origin = 0;
};

// How one elimination went: the leading matrix's reciprocal condition (below kLeadCondition: the
// pose's eigenproblem is ill-conditioned; NaN: the pose's quantities are not finite), and whether
// a cluster held more than kMaxSplit eigenvalues (a curve of solutions at one value of the
// eliminated joint: a defective multiple eigenvalue whose computed copies scatter by
// eps^(1 / order), and whose null space holds the curve's vectors besides the roots').
struct EliminationInfo {
  double lead_condition = 0.0;
  bool degenerate = false;
};

namespace candidates_detail {

using Rows6 = Eigen::Matrix<double, 6, kProducts>;

// p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p of l = F's z axis, p = F's origin.
inline Eigen::Matrix<double, 1, kQuantities> quantities(const Frame& F) {
  const double l0 = F.R[0][2], l1 = F.R[1][2], l2 = F.R[2][2];
  const double p0 = F.p[0], p1 = F.p[1], p2 = F.p[2];
  const double pp = p0 * p0 + p1 * p1 + p2 * p2;
  const double pl = p0 * l0 + p1 * l1 + p2 * l2;
  Eigen::Matrix<double, 1, kQuantities> out;
  out << p0, p1, p2, l0, l1, l2, pp, pl, p1 * l2 - p2 * l1, p2 * l0 - p0 * l2, p0 * l1 - p1 * l0,
      pp * l0 - 2.0 * pl * p0, pp * l1 - 2.0 * pl * p1, pp * l2 - 2.0 * pl * p2;
  return out;
}

// The 12 x 12 matrix of six equations W (6 x 9 over x_a^i x_b^j, i, j <= 2): W, and W times x_a.
inline Matrix12 stacked(const Rows6& W) {
  Matrix12 M = Matrix12::Zero();
  M.block<6, kProducts>(0, 0) = W;
  M.block<6, kProducts>(6, 3) = W;
  return M;
}

// The reciprocal condition (1-norm) of M and its inverse (0 where M is singular).
inline double reciprocal_condition(const Matrix12& M, Matrix12& inverse) {
  inverse = M.partialPivLu().inverse();
  const double norm = M.cwiseAbs().colwise().sum().maxCoeff();
  const double inverse_norm = inverse.cwiseAbs().colwise().sum().maxCoeff();
  const double ratio = 1.0 / (norm * inverse_norm);
  return ratio > 0.0 ? ratio : 0.0;  // NaN (an exactly singular M): 0
}

// A near-real eigenvalue as the angle of the eliminated joint (relative to lead).
struct Angle {
  double real = 0.0, imaginary = 0.0;
};

}  // namespace candidates_detail

// The starts of every root the eigenproblem of T_dh (DH frame 0 -> DH frame 6 of the exact
// chain) holds, appended to `out`; where every leading matrix is ill-conditioned, by QZ on the
// pencil. A `moved` pose (all_candidates) is solved by QZ whatever
// its leading matrix's condition: it lies within the move of a pose whose matrix polynomial is
// singular, or nearly, so the companion's A^-1 (reciprocal condition 1.4e-7 on a tilted-UR5
// special pose) amplifies rounding into its eigenvalues (1e-4 apart between two QR codes there,
// two roots' eigenvalues 1.8e-3 apart: one's null vector came out a mixture, its start 0.4 rad
// off, and which root was lost depended on rounding), while QZ stays backward stable (that
// start: 1e-3 rad off, the size of the move). Near-real eigenvalues (angle's imaginary part
// within the band) whose angles lie within kCluster of each other are one cluster of m: at each
// distinct member the m-dimensional null space of M is split into one monomial vector per root
// (m = 1: inverse iteration), and each vector's joints are back-substituted.
inline EliminationInfo candidates(const Elimination& el, const Frame& T_dh, std::vector<Start>& out,
                                  bool moved = false) {
  using namespace candidates_detail;
  EliminationInfo info;
  const Frame target = el.reversed ? inverse(T_dh) : T_dh;
  Frame H = el.D0_inverse * target * el.E_inverse;
  for (int r = 0; r < 3; ++r) H.p[r] /= el.scale;
  Eigen::Matrix<double, kProducts, kQuantities> values;
  for (int s = 0; s < kProducts; ++s) values.row(s) = quantities(el.before[s] * H * el.after[s]);
  if (!values.allFinite()) {
    info.lead_condition = NAN;
    return info;
  }
  const Eigen::Matrix<double, kProducts, kQuantities> G = el.right_inverse * values;
  Right right;
  right.Q = G.topRows<8>().transpose();
  right.r = G.row(8).transpose();
  EliminatingRows N;  // N Q = 0: they eliminate the right side's products
  factor_right(el, right, N);
  const Rows6 Pc = N * el.P[0], Ps = N * el.P[1];
  Rows6 P1 = N * el.P[2];
  P1.col(8) -= N * right.r;
  const auto M_at = [&](double angle) {
    return stacked((Pc * std::cos(angle) + Ps * std::sin(angle) + P1) * el.half2);
  };
  // leading matrix: the first of M at four angles conditioned within kCompanionCondition (its
  // companion's eigenvalues, deflated where the arm has spurious ones), else the best of them
  // (QZ on the pencil); a moved pose (always QZ) takes the first within kLeadCondition
  double best = -1.0, lead = el.shift;
  Matrix12 A, A_inverse, inverse_here;
  bool companion = false;
  for (int quarter = 0; quarter < 4; ++quarter) {
    const double angle = el.shift + quarter * 0.5 * kPi;
    const Matrix12 M = M_at(angle + kPi);
    const double ratio = reciprocal_condition(M, inverse_here);
    if (ratio > best) best = ratio, lead = angle, A = M, A_inverse = inverse_here;
    if (moved ? ratio >= kLeadCondition : ratio >= kCompanionCondition) {
      companion = !moved;
      break;
    }
  }
  info.lead_condition = best;
  // B and C of M(x) = A x^2 + B x + C with theta_k = lead + 2 atan(x)
  const double cs = std::cos(lead), sn = std::sin(lead);
  const Matrix12 B = stacked(2.0 * (Ps * cs - Pc * sn) * el.half2);
  const Matrix12 C = M_at(lead);
  Eigenvalues eigenvalues;
  int count = kEigenvalues;
  if (companion) {
    count = companion_eigenvalues(A_inverse, B, C, el.has_spurious ? &el.spurious : nullptr,
                                  eigenvalues);
    if (count == 0) return info;
  } else {
    Matrix24 left = Matrix24::Zero(), right_matrix = Matrix24::Identity();
    left.topRightCorner<kMonomials, kMonomials>().setIdentity();
    left.bottomLeftCorner<kMonomials, kMonomials>() = -C;
    left.bottomRightCorner<kMonomials, kMonomials>() = -B;
    right_matrix.bottomRightCorner<kMonomials, kMonomials>() = A;
    if (!pencil_eigenvalues(left, right_matrix, eigenvalues)) return info;
  }
  // near-real eigenvalues as angles, sorted by the real part
  std::array<Angle, kEigenvalues> angles;
  int kept = 0;
  for (int index = 0; index < count; ++index) {
    const std::complex<double> x = eigenvalues(index);
    const std::complex<double> angle =
        std::abs(x) > kInfinite ? std::complex<double>(kPi, 0.0) : 2.0 * std::atan(x);
    if (!(std::abs(angle.imag()) <= el.band)) continue;
    if (!(std::abs(angle.real()) < INFINITY)) continue;
    if (x.imag() < 0.0 && std::abs(angle.imag()) > kCluster) continue;  // a pair's second
    int position = kept++;
    while (position > 0 && angles[position - 1].real > angle.real()) {
      angles[position] = angles[position - 1];
      --position;
    }
    angles[position] = {angle.real(), angle.imag()};
  }
  Vector12 vector;
  Basis basis, split_vectors;
  for (int first = 0; first < kept;) {
    int last = first + 1;
    while (last < kept && angles[last].real - angles[last - 1].real < kCluster) ++last;
    const int m = std::min(last - first, kMaxSplit);
    if (last - first > kMaxSplit) info.degenerate = true;
    for (int member = first; member < last; ++member) {
      if (member > first && angles[member].real == angles[member - 1].real) continue;
      const double angle = angles[member].real;
      const std::uint32_t origin =
          (std::abs(angles[member].imaginary) > kCluster ? std::uint32_t{kPaired} : 0u) |
          (m > 1 ? std::uint32_t{kShared} : 0u);
      if (m == 1) {
        if (!null_vector(A, B, C, 0.5 * angle, vector)) continue;
        out.push_back({back_substitute(el, right, H, lead + angle, vector.data()), origin});
        continue;
      }
      if (!null_space(A, B, C, 0.5 * angle, m, basis)) continue;
      split(basis, split_vectors);
      for (int v = 0; v < m; ++v) {
        const Vector12 column = split_vectors.col(v);
        out.push_back({back_substitute(el, right, H, lead + angle, column.data()), origin});
      }
    }
    first = last;
  }
  return info;
}

// candidates() of T_dh (by QZ where its eigenproblem is ill-conditioned: the matrix polynomial
// is singular, or nearly, at this pose) and, there and where an eigenvalue is degenerate (a
// curve of solutions at one value of the eliminated joint), those of the pose moved by
// moves.motion(1), whose eigenproblem is regular (solved by QZ, backward stable) with
// simple eigenvalues: every real root of the moved pose is among its eigenvalues, and every
// regular root of T_dh lies near one of them (docs/general6r.md, "Every root"). With the moved
// pose, the fallback starts are starts too: near a highly degenerate singular set (a stretched
// arm with a free wrist) a moved pose's own eigenproblem can lose the roots it has there.
// The pose's own eigenvalues stay starts where it is ill-conditioned: a target a hair off a pose
// with a curve of solutions (the folded M-430iA/2P, q3 = 180 deg, axis 5 on axis 1, its target
// rounded 2e-10 m off) has no root near the curve but a valley whose floor misses the target by
// less than the tolerance (5e-11 m): near-solutions that verify. They exist only within the
// tolerance of the pose, so the moved pose (1e-3 away) has nothing there to follow back, and
// its starts near the curve do not reach the floor by Newton; the pose's own polynomial is
// nearly singular (its leading matrix's reciprocal condition ~1e-10 there, 1.5e-3 on the exact
// pose), but QZ is backward stable and its near-real eigenvalues put starts within 1e-5 of the
// floor (docs/general6r.md, "The folded M-430iA/2P a hair off"). Extra starts cost a QZ on such
// poses and never a root: each is verified like any other. Most of them are noise (the pencil is
// nearly singular): they are refined as a near-real pair's starts are (kIll: refine_paired,
// which stops a start that cycles with no root near it), a start near a root or a floor
// converges within its crawl.
// Returns whether the moved pose was used (false also where T_dh's quantities are not finite).
// `fallback` false leaves out the fixed starts (a second arrangement's: the first had them).
inline bool all_candidates(const Elimination& el, const Moves& moves, const Frame& T_dh,
                           std::vector<Start>& out, bool fallback = true) {
  const std::size_t own = out.size();
  const EliminationInfo info = candidates(el, T_dh, out);
  if (std::isnan(info.lead_condition)) return false;
  if (info.lead_condition >= kLeadCondition && !info.degenerate) return false;
  if (info.lead_condition < kLeadCondition) {
    for (std::size_t i = own; i < out.size(); ++i) out[i].origin |= kIll;
  }
  const std::size_t first = out.size();
  candidates(el, moves.motion(1.0) * T_dh, out, true);
  for (std::size_t i = first; i < out.size(); ++i) out[i].origin |= kMoved;
  if (fallback) {
    for (const Joints& q : moves.fallback) out.push_back({q, 0});
  }
  return true;
}

}  // namespace dhkin::general6r
