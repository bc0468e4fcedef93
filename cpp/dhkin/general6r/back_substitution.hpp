// Back-substitution of the general 6R elimination: from the eliminated joint and its two
// neighbours (an eigenvalue and its monomial vector) the other three joints.
//
// The right side of the elimination holds two joints, a and b; its 14 quantities are linear in
// y = (cos, sin, 1) of a times (cos, sin, 1) of b, less the constant product (8 values, index
// 3 i + j): Q y = P x - r. Where Q has full rank, y is its least-squares solution. Where it has
// not (a free joint: axis 6 on axis 1 makes the right side depend on a - b alone when a and b
// are joints 1 and 6), the least-squares y of least norm is no product of angles at all; the
// angles are then fitted to the equations directly (right_joints).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <utility>

#include "dhkin/general6r/decomposed_types.hpp"  // RightSide
#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/null_space.hpp"

namespace dhkin::general6r {

// Rounds of alternation in right_joints (each fits one angle with the other held): a right side
// that depends on a - b alone is fitted exactly in the first; four let a start a quarter turn off
// settle.
constexpr int kAlternations = 4;

using Products = Eigen::Matrix<double, 8, 1>;        // y: the right side's non-constant products
// RightSide (Q): decomposed_types.hpp.
using Quantities = Eigen::Matrix<double, kQuantities, 1>;

// The right side of one pose: Q y = rhs, with Q's rank and pseudo-inverse.
struct Right {
  RightSide Q;
  Quantities r;  // the constant product's column
  int rank = 8;
  Eigen::Matrix<double, 8, kQuantities> pseudo_inverse;
};

// y (8) = (cos, sin, 1) of a times (cos, sin, 1) of b, index 3 i + j, less the last.
inline Products products(double a, double b) {
  const double first[3] = {std::cos(a), std::sin(a), 1.0};
  const double second[3] = {std::cos(b), std::sin(b), 1.0};
  Products y;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (3 * i + j < 8) y(3 * i + j) = first[i] * second[j];
    }
  }
  return y;
}

// The angle of the free joint (a when `free_first`, else b) that best fits Q y = rhs with the
// other joint at `held`: y is linear in its (cos, sin), two unknowns by least squares, the angle
// from their direction.
inline double fit(const RightSide& Q, const Quantities& rhs, double held, bool free_first) {
  Products cos_part = Products::Zero(), sin_part = Products::Zero(), constant = Products::Zero();
  const double other[3] = {std::cos(held), std::sin(held), 1.0};
  for (int t = 0; t < 3; ++t) {
    if (free_first) {  // y[3 i + t] = (cos a, sin a, 1)[i] * other[t]
      cos_part(t) = other[t];
      sin_part(3 + t) = other[t];
      if (6 + t < 8) constant(6 + t) = other[t];
    } else {  // y[3 t + j] = other[t] * (cos b, sin b, 1)[j]
      cos_part(3 * t) = other[t];
      sin_part(3 * t + 1) = other[t];
      if (3 * t + 2 < 8) constant(3 * t + 2) = other[t];
    }
  }
  const Quantities u = Q * cos_part, v = Q * sin_part;
  const Quantities target = rhs - Q * constant;
  const double uu = u.dot(u), uv = u.dot(v), vv = v.dot(v);
  const double ut = u.dot(target), vt = v.dot(target);
  const double det = uu * vv - uv * uv;
  if (!(std::abs(det) > 0.0)) return std::atan2(vt, ut);
  return std::atan2(uu * vt - uv * ut, vv * ut - uv * vt);
}

// The right side's joints (a, b) from Q y = rhs: y's angles where Q has full rank; else the
// angles that fit best of alternating fits (kAlternations rounds) from either joint held at each
// quarter turn (a joint left free by the pose takes the value it was held at).
inline std::pair<double, double> right_joints(const Right& right, const Quantities& rhs) {
  if (right.rank >= 8) {
    const Products y = right.pseudo_inverse * rhs;
    return {std::atan2(y(5), y(2)), std::atan2(y(7), y(6))};
  }
  double best = INFINITY, best_a = 0.0, best_b = 0.0;
  for (const bool hold_b : {true, false}) {
    for (int quarter = 0; quarter < 4; ++quarter) {
      const double start = 0.5 * kPi * quarter;
      double a = 0.0, b = 0.0;
      if (hold_b) {
        b = start;
        a = fit(right.Q, rhs, b, true);
      } else {
        a = start;
        b = fit(right.Q, rhs, a, false);
      }
      for (int round = 0; round < kAlternations - 1; ++round) {
        b = fit(right.Q, rhs, a, false);
        a = fit(right.Q, rhs, b, true);
      }
      const double residual = (right.Q * products(a, b) - rhs).squaredNorm();
      if (residual < best) best = residual, best_a = a, best_b = b;
    }
  }
  return {best_a, best_b};
}

// The joint values (URDF) of the model angle theta_k (the eigenvalue) and those of the monomial
// vector (theta_k+1, theta_k+2): the right side's two joints from its 14 equations, the dropped
// joint from the orientation. H: the pose in model frames (scaled lengths).
inline Joints back_substitute(const Elimination& el, const Right& right, const Frame& H,
                              double theta_k, const double* vector) {
  const int k = el.k;
  Joints theta{};
  // each angle's cosine and sine once: the products below and the frames use the same values
  Joints cosine{}, sine{};
  const auto set = [&](int j, double angle) {
    theta[j] = angle, cosine[j] = std::cos(angle), sine[j] = std::sin(angle);
  };
  set(k, theta_k);
  set(k + 1, ratio_angle(vector, false));
  set(k + 2, ratio_angle(vector, true));
  const double b1[3] = {cosine[k + 1], sine[k + 1], 1.0};
  const double b2[3] = {cosine[k + 2], sine[k + 2], 1.0};
  Eigen::Matrix<double, kProducts, 1> x45;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) x45(3 * i + j) = b1[i] * b2[j];
  }
  const Coefficients left = el.P[0] * cosine[k] + el.P[1] * sine[k] + el.P[2];
  const Quantities rhs = left * x45 - right.r;
  int first = -1, second = -1;
  for (int j = 0; j < kDof; ++j) {
    if (j < k || j > k + 3) (first < 0 ? first : second) = j;
  }
  const auto [a, b] = right_joints(right, rhs);
  set(first, a);
  set(second, b);
  const int dropped = k + 3;
  Frame pre, post;
  for (int j = 0; j < dropped; ++j) pre = pre * dh_frame(cosine[j], sine[j], el.rows[j]);
  for (int j = dropped + 1; j < kDof; ++j) post = post * dh_frame(cosine[j], sine[j], el.rows[j]);
  const Frame A = inverse(pre) * H * inverse(post);
  theta[dropped] = std::atan2(A.R[1][0], A.R[0][0]);
  return el.joint_values(theta);
}

}  // namespace dhkin::general6r
