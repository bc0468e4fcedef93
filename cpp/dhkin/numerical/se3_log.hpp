// The logarithm of a rigid transform and its Jacobian, as Pinocchio computes them (log3, log6,
// Jlog3, Jlog6 of pinocchio/spatial/log.hxx, version 3.x/4.x): the numerical IK's pose error is
// e = log6(T_target^-1 T(q)) and its derivative Jlog6(T_target^-1 T(q)) J_local(q). The same
// formulas and branch points, so the descent takes the steps the Pinocchio version took, up to
// rounding. Lengths in metres, angles in radians; a twist is [v; w] (linear, then angular).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <limits>

namespace dhkin::numerical {

using Matrix3 = Eigen::Matrix3d;
using Vector3 = Eigen::Vector3d;
using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

// Pinocchio's TaylorSeriesExpansion<double>::precision<degree>(): eps^(1 / (degree + 1)), the
// argument below which a series of that degree is exact to rounding (degree 2: 6.1e-6, degree
// 3: 1.2e-4).
inline double taylor_precision(int degree) {
  return std::pow(std::numeric_limits<double>::epsilon(), 1.0 / (degree + 1));
}

// The vector v of the skew part of M: (M - M^T) / 2 = [v]x.
inline Vector3 unskew(const Matrix3& M) {
  return {0.5 * (M(2, 1) - M(1, 2)), 0.5 * (M(0, 2) - M(2, 0)), 0.5 * (M(1, 0) - M(0, 1))};
}

// M += [v]x.
inline void add_skew(const Vector3& v, Matrix3& M) {
  M(0, 1) -= v[2], M(0, 2) += v[1];
  M(1, 0) += v[2], M(1, 2) -= v[0];
  M(2, 0) -= v[1], M(2, 1) += v[0];
}

namespace detail {

// Angle and axis of R from its column i0 (Pinocchio's compute_theta_axis), for angles near pi.
template <int i0>
inline void theta_axis(double val, const Matrix3& R, double& angle, Vector3& axis) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  constexpr int i1 = (i0 + 1) % 3, i2 = (i0 + 2) % 3;
  const double s = std::sqrt(val + eps + eps * eps) * (R(i2, i1) >= R(i1, i2) ? 1.0 : -1.0);
  axis[i0] = s / 2.0;
  axis[i1] = 1.0 / (2.0 * s) * (R(i1, i0) + R(i0, i1));
  axis[i2] = 1.0 / (2.0 * s) * (R(i2, i0) + R(i0, i2));
  const double w = 1.0 / (2.0 * s) * (R(i2, i1) - R(i1, i2));
  const double axis_norm = axis.norm();
  angle = 2.0 * std::atan2(axis_norm, w);
  axis /= axis_norm;
}

}  // namespace detail

// The rotation vector of R (angle theta in [0, pi] times the unit axis), R renormalised first.
inline Vector3 log3(const Matrix3& R, double& theta) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  const double pi = 3.14159265358979323846;
  Matrix3 Rn;
  Rn.col(0) = R.col(0) / R.col(0).norm();
  Rn.col(1) = R.col(1) / R.col(1).norm();
  Rn.col(2) = Rn.col(0).cross(Rn.col(1));
  Rn.col(0) = Rn.col(1).cross(Rn.col(2));
  const double tr = Rn.trace();
  const double cos_value = (tr - 1.0) / 2.0;
  const double prec = taylor_precision(2);

  Vector3 val;
  val.array() = 2.0 * Rn.diagonal().array() - tr + 1.0;
  Vector3 axis_0, axis_1, axis_2;
  double theta_0, theta_1, theta_2;
  detail::theta_axis<0>(val[0], Rn, theta_0, axis_0);
  detail::theta_axis<1>(val[1], Rn, theta_1, axis_1);
  detail::theta_axis<2>(val[2], Rn, theta_2, axis_2);
  const int largest = val[0] >= val[1] ? (val[0] >= val[2] ? 0 : 2) : (val[1] >= val[2] ? 1 : 2);
  const double theta_singular = largest == 0 ? theta_0 : largest == 1 ? theta_1 : theta_2;
  const Vector3 axis_singular = largest == 0 ? axis_0 : largest == 1 ? axis_1 : axis_2;

  const double acos_expansion = std::sqrt(2.0 * (1.0 - cos_value) + eps * eps);
  const double theta_nominal =
      tr <= 3.0 - prec ? (tr >= -1.0 + prec ? std::acos(cos_value) : pi - acos_expansion)
                       : acos_expansion;
  const Vector3 antisymmetric = unskew(Rn);
  const double n2 = antisymmetric.squaredNorm();
  const double t = theta_nominal >= prec ? theta_nominal / std::sin(theta_nominal)
                                         : 1.0 + n2 / 6.0 + n2 * n2 * 3.0 / 40.0;
  if (cos_value >= -1.0 + prec) {
    theta = theta_nominal;
    return t * antisymmetric;
  }
  theta = theta_singular;
  return theta_singular * axis_singular;
}

// The derivative of log3 at a rotation of angle theta and rotation vector w.
inline Matrix3 jlog3(double theta, const Vector3& w) {
  const double st = std::sin(theta), ct = std::cos(theta);
  const double st_1mct = st / (1.0 - ct);
  const double prec = taylor_precision(3);
  const double alpha = theta < prec ? 1.0 / 12.0 + theta * theta / 720.0
                                    : 1.0 / (theta * theta) - st_1mct / (2.0 * theta);
  const double diag_value = theta < prec ? 0.5 * (2.0 - theta * theta / 6.0)
                                         : 0.5 * (theta * st_1mct);
  Matrix3 J = alpha * w * w.transpose();
  J.diagonal().array() += diag_value;
  add_skew(0.5 * w, J);
  return J;
}

// log6 of (R, p): the twist [v; w] whose exponential is the transform.
inline Vector6 log6(const Matrix3& R, const Vector3& p) {
  const Vector3 antisymmetric = unskew(R);
  const double t2 = antisymmetric.squaredNorm();
  double theta = 0.0;
  const double tr = R.trace();
  const Vector3 w = log3(R, theta);
  const double st = std::sin(theta), ct = std::cos(theta);
  const bool small = tr >= 3.0 - taylor_precision(2);
  const double alpha = small ? 1.0 - t2 / 12.0 - t2 * t2 / 720.0
                             : theta * st / (2.0 * (1.0 - ct));
  const double beta = small ? 1.0 / 12.0 + t2 / 720.0
                            : 1.0 / (theta * theta) - st / (2.0 * theta * (1.0 - ct));
  Vector6 out;
  out.head<3>() = alpha * p - 0.5 * w.cross(p) + (beta * w.dot(p)) * w;
  out.tail<3>() = w;
  return out;
}

// The derivative of log6 at (R, p) with respect to a motion of the transform expressed in its
// own (local) frame.
inline Matrix6 jlog6(const Matrix3& R, const Vector3& p) {
  double t = 0.0;
  const Vector3 w = log3(R, t);
  const Matrix3 A = jlog3(t, w);
  const double t2 = t * t;
  const double tinv = 1.0 / t, t2inv = tinv * tinv;
  const double st = std::sin(t), ct = std::cos(t);
  const double inv_2_2ct = 1.0 / (2.0 * (1.0 - ct));
  const bool small = t < taylor_precision(3);
  const double beta = small ? 1.0 / 12.0 + t2 / 720.0 : t2inv - st * tinv * inv_2_2ct;
  const double beta_dot_over_theta =
      small ? 1.0 / 360.0 : -2.0 * t2inv * t2inv + (1.0 + st * tinv) * t2inv * inv_2_2ct;
  const double wTp = w.dot(p);
  const Vector3 v3 = (beta_dot_over_theta * wTp) * w - (t2 * beta_dot_over_theta + 2.0 * beta) * p;
  Matrix3 C = v3 * w.transpose();
  C += beta * w * p.transpose();
  C.diagonal().array() += wTp * beta;
  add_skew(0.5 * p, C);
  Matrix6 J;
  J.topLeftCorner<3, 3>() = A;
  J.topRightCorner<3, 3>() = C * A;
  J.bottomLeftCorner<3, 3>().setZero();
  J.bottomRightCorner<3, 3>() = A;
  return J;
}

}  // namespace dhkin::numerical
