// What the binding units (cpp/bindings*.cpp) share: numpy arrays in and out and a chain built
// from its parts (a frame from a row-major 4 x 4 is pose.hpp's raw_frame). Binding code only: the
// kinematics in cpp/dhkin/ never sees nanobind.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstddef>
#include <stdexcept>

#include "dhkin/chain.hpp"
#include "dhkin/frame.hpp"
#include "dhkin/pose.hpp"

namespace dhkin::bindings {

// A C-contiguous numpy array of T on the CPU, read only (Input) or written (Output).
template <class T, class... Shape>
using Input = nanobind::ndarray<const T, nanobind::numpy, nanobind::c_contig,
                                nanobind::device::cpu, Shape...>;
template <class T, class... Shape>
using Output = nanobind::ndarray<T, nanobind::numpy, nanobind::c_contig, nanobind::device::cpu,
                                 Shape...>;

// A chain (chain.hpp) of n joints from row-major numbers: before (n x 16) the constant frames
// P_j, direction (n) and offset (n) of v_j = direction q_j + offset, tail (16) P_tail; revolute
// (n) the joints' kinds, or null for n revolute joints. The caller has checked the lengths.
inline Chain chain_of(std::size_t n, const double* before, const bool* revolute,
                      const double* direction, const double* offset, const double* tail) {
  Chain chain;
  chain.joints.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    chain.joints[j].before = raw_frame(before + 16 * j);
    chain.joints[j].revolute = revolute == nullptr || revolute[j];
    chain.joints[j].direction = direction[j];
    chain.joints[j].offset = offset[j];
  }
  chain.tail = raw_frame(tail);
  return chain;
}

// A chain from its parts, as dhkin.ik.plan.chain_parts and dhkin.ik.numerical.task._Chain.parts
// give them: before (n, 4, 4), revolute (n,), direction (n,), offset (n,), tail (4, 4); 1 to
// kMaxJoints joints.
inline Chain make_chain(Input<double, nanobind::shape<-1, 4, 4>> before,
                        Input<bool, nanobind::ndim<1>> revolute,
                        Input<double, nanobind::ndim<1>> direction,
                        Input<double, nanobind::ndim<1>> offset,
                        Input<double, nanobind::shape<4, 4>> tail) {
  const std::size_t n = before.shape(0);
  if (revolute.shape(0) != n || direction.shape(0) != n || offset.shape(0) != n) {
    throw std::invalid_argument("chain: before, revolute, direction and offset differ in length");
  }
  if (n < 1 || n > static_cast<std::size_t>(kMaxJoints)) {
    throw std::invalid_argument("chain: expected 1 to 32 joints");
  }
  return chain_of(n, before.data(), revolute.data(), direction.data(), offset.data(),
                  tail.data());
}

}  // namespace dhkin::bindings
