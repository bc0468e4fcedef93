// dhkin._core: the Python module of the compiled core (nanobind).
//
// Arrays in, arrays out. Plans are built once per table from named values (dhkin.ik.plan); the
// per-pose functions take C-contiguous float64 arrays (converted when given otherwise) and write
// into arrays the caller allocated, releasing the GIL, so that Python threads can share a batch.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "array_io.hpp"
#include "exact_roots_binding.hpp"
#include "dhkin/batch.hpp"
#include "dhkin/chain.hpp"
#include "dhkin/expand.hpp"
#include "dhkin/pipeline.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/pose.hpp"
#include "dhkin/refine_lanes_exact.hpp"
#include "dhkin/right_svd.hpp"
#include "dhkin/rows.hpp"
#include "dhkin/solver.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using dhkin::Frame;
using dhkin::Joints;
using dhkin::kBranches;
using dhkin::kDof;

using dhkin::bindings::Input;
using dhkin::bindings::Output;
using dhkin::raw_frame;
using dhkin::bindings::make_chain;

// ---- reading named values (a plan's fields come as a dict of arrays) -------------------------

std::vector<double> values_of(const nb::dict& fields, const char* name, std::size_t size) {
  if (!fields.contains(name)) throw std::invalid_argument(std::string("missing field ") + name);
  const auto array = nb::cast<Input<double>>(fields[name]);
  if (array.size() != size) {
    throw std::invalid_argument(std::string("field ") + name + ": expected " +
                                std::to_string(size) + " values, got " +
                                std::to_string(array.size()));
  }
  return std::vector<double>(array.data(), array.data() + size);
}

double scalar(const nb::dict& f, const char* name) { return values_of(f, name, 1)[0]; }

dhkin::Vec3 vec3(const nb::dict& f, const char* name) {
  const auto v = values_of(f, name, 3);
  return {v[0], v[1], v[2]};
}

dhkin::Mat3 mat3(const nb::dict& f, const char* name) {
  const auto v = values_of(f, name, 9);
  dhkin::Mat3 m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.m[r][c] = v[3 * r + c];
  }
  return m;
}

dhkin::Planar planar(const nb::dict& f, const char* name) {
  const auto v = values_of(f, name, 2);
  return {v[0], v[1]};
}

Frame frame(const nb::dict& f, const char* name) {
  const auto v = values_of(f, name, 12);
  return raw_frame(v.data());
}

// Every key of `fields` must be one of `names`.
void check_keys(const nb::dict& fields, std::initializer_list<const char*> names,
                const char* what) {
  for (auto item : fields) {
    const std::string key = nb::cast<std::string>(item.first);
    bool found = false;
    for (const char* name : names) found = found || key == name;
    if (!found) throw std::invalid_argument(std::string(what) + ": unknown field " + key);
  }
}

dhkin::SphericalGeometry spherical_geometry(const nb::dict& f) {
  check_keys(f, {"centre_in_flange", "origin", "forward", "lateral", "up", "shoulder_offset",
                 "lateral_offset", "signs", "wrist_frame", "target_to_wrist", "tilt",
                 "wrist_directions", "scale", "upper_arm", "forearm", "upper_length",
                 "forearm_length", "bend_at_zero", "wrist_at_zero", "slide", "slide_along",
                 "slide_offset", "spread"},
             "spherical geometry");
  dhkin::SphericalGeometry g;
  g.centre_in_flange = vec3(f, "centre_in_flange");
  g.origin = vec3(f, "origin");
  g.forward = vec3(f, "forward");
  g.lateral = vec3(f, "lateral");
  g.up = vec3(f, "up");
  g.shoulder_offset = scalar(f, "shoulder_offset");
  g.lateral_offset = scalar(f, "lateral_offset");
  const auto signs = values_of(f, "signs", 3);
  const auto directions = values_of(f, "wrist_directions", 3);
  for (int k = 0; k < 3; ++k) g.signs[k] = signs[k], g.wrist_directions[k] = directions[k];
  g.wrist_frame = mat3(f, "wrist_frame");
  g.target_to_wrist = mat3(f, "target_to_wrist");
  g.tilt = scalar(f, "tilt");
  g.scale = scalar(f, "scale");
  g.upper_arm = planar(f, "upper_arm");
  g.forearm = planar(f, "forearm");
  g.upper_length = scalar(f, "upper_length");
  g.forearm_length = scalar(f, "forearm_length");
  g.bend_at_zero = scalar(f, "bend_at_zero");
  g.wrist_at_zero = planar(f, "wrist_at_zero");
  g.slide = planar(f, "slide");
  g.slide_along = scalar(f, "slide_along");
  g.slide_offset = scalar(f, "slide_offset");
  g.spread = scalar(f, "spread");
  return g;
}

dhkin::OffsetGeometry offset_geometry(const nb::dict& f) {
  check_keys(f, {"directions", "points", "n", "side", "plane_x", "plane_y", "wrist_in_flange",
                 "wrist_point", "home_rotation", "home_inverse", "upper_arm", "forearm",
                 "axis3_x_forearm", "lateral", "left_sign", "lateral_sign", "up_sign", "psi",
                 "sign3", "sign4", "upper_length", "forearm_length", "elbow_alpha", "elbow_base",
                 "elbow_turn", "scale", "spread"},
             "offset geometry");
  dhkin::OffsetGeometry g;
  const auto directions = values_of(f, "directions", 18);
  const auto points = values_of(f, "points", 18);
  for (int j = 0; j < 6; ++j) {
    g.directions[j] = {directions[3 * j], directions[3 * j + 1], directions[3 * j + 2]};
    g.points[j] = {points[3 * j], points[3 * j + 1], points[3 * j + 2]};
  }
  g.n = vec3(f, "n");
  g.side = vec3(f, "side");
  g.plane_x = vec3(f, "plane_x");
  g.plane_y = vec3(f, "plane_y");
  g.wrist_in_flange = vec3(f, "wrist_in_flange");
  g.wrist_point = vec3(f, "wrist_point");
  g.home_rotation = mat3(f, "home_rotation");
  g.home_inverse = frame(f, "home_inverse");
  g.upper_arm = vec3(f, "upper_arm");
  g.forearm = vec3(f, "forearm");
  g.axis3_x_forearm = vec3(f, "axis3_x_forearm");
  g.lateral = scalar(f, "lateral");
  g.left_sign = scalar(f, "left_sign");
  g.lateral_sign = scalar(f, "lateral_sign");
  g.up_sign = scalar(f, "up_sign");
  g.psi = scalar(f, "psi");
  g.sign3 = scalar(f, "sign3");
  g.sign4 = scalar(f, "sign4");
  g.upper_length = scalar(f, "upper_length");
  g.forearm_length = scalar(f, "forearm_length");
  g.elbow_alpha = scalar(f, "elbow_alpha");
  g.elbow_base = scalar(f, "elbow_base");
  g.elbow_turn = scalar(f, "elbow_turn");
  g.scale = scalar(f, "scale");
  g.spread = scalar(f, "spread");
  return g;
}

dhkin::Chain chain_of(const nb::dict& f, const char* name) {
  if (!f.contains(name)) throw std::invalid_argument(std::string("missing field ") + name);
  const nb::dict parts = nb::cast<nb::dict>(f[name]);
  check_keys(parts, {"before", "revolute", "direction", "offset", "tail"}, name);
  return make_chain(nb::cast<Input<double, nb::shape<-1, 4, 4>>>(parts["before"]),
                    nb::cast<Input<bool, nb::ndim<1>>>(parts["revolute"]),
                    nb::cast<Input<double, nb::ndim<1>>>(parts["direction"]),
                    nb::cast<Input<double, nb::ndim<1>>>(parts["offset"]),
                    nb::cast<Input<double, nb::shape<4, 4>>>(parts["tail"]));
}

dhkin::Plan make_plan(const nb::dict& f) {
  check_keys(f, {"family", "refine", "seed_angle", "seed_length", "deviation", "band_angle",
                 "lever", "free_joints", "geometry", "chain", "ideal", "path", "limits"},
             "plan");
  dhkin::Plan plan;
  const int family = nb::cast<int>(f["family"]);
  if (family < 1 || family > 3) throw std::invalid_argument("plan: unknown family id");
  plan.family = static_cast<dhkin::Family>(family);
  plan.refine = nb::cast<bool>(f["refine"]);
  plan.seed_angle = nb::cast<double>(f["seed_angle"]);
  plan.seed_length = nb::cast<double>(f["seed_length"]);
  plan.deviation = nb::cast<double>(f["deviation"]);
  plan.band_angle = nb::cast<double>(f["band_angle"]);
  plan.lever = nb::cast<double>(f["lever"]);
  const auto free = nb::cast<std::tuple<int, int, int>>(f["free_joints"]);
  plan.free_wrist = std::get<0>(free);
  plan.free_elbow = std::get<1>(free);
  plan.free_shoulder = std::get<2>(free);
  const nb::dict geometry = nb::cast<nb::dict>(f["geometry"]);
  if (plan.family == dhkin::Family::offset_wrist) {
    plan.offset = offset_geometry(geometry);
  } else {
    plan.spherical = spherical_geometry(geometry);
  }
  plan.chain = chain_of(f, "chain");
  plan.ideal = chain_of(f, "ideal");
  if (plan.chain.dof() != kDof || plan.ideal.dof() != kDof) {
    throw std::invalid_argument("plan: the closed-form families have 6 joints");
  }
  const auto path = values_of(f, "path", 6 * (kDof + 1));
  for (int j = 0; j <= kDof; ++j) {
    plan.path.push_back({{path[6 * j], path[6 * j + 1], path[6 * j + 2]},
                         {path[6 * j + 3], path[6 * j + 4], path[6 * j + 5]}});
  }
  const auto limits = values_of(f, "limits", 2 * kDof);
  for (int j = 0; j < kDof; ++j) plan.limits[j] = {limits[2 * j], limits[2 * j + 1]};
  return plan;
}

dhkin::TargetFrames target_frames(const Input<double, nb::shape<2, 4, 4>>& frames) {
  return dhkin::TargetFrames::from(raw_frame(frames.data()), raw_frame(frames.data() + 16));
}

Joints joints_of(const double* values) {
  Joints q;
  for (int j = 0; j < kDof; ++j) q[j] = values[j];
  return q;
}

// A new numpy array owning its data.
template <class T>
Output<T> new_array(std::initializer_list<std::size_t> shape) {
  std::size_t size = 1;
  for (std::size_t s : shape) size *= s;
  T* data = new T[size > 0 ? size : 1]();
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<T*>(p); });
  return Output<T>(data, shape.size(), shape.begin(), owner);
}

// One pose's answer: its solutions (one per branch inline, more with every 2pi copy) and what
// happened to the pose; dhkin.ik.result.IKSolutions reads its arrays when they are asked for.
class Answer {
 public:
  dhkin::PoseInfo info;
  dhkin::JointMask revolute{};

  std::size_t count() const { return stored_; }
  // The number of solutions, or -1 when the pose or the seed was rejected (info.status).
  long found() const { return info.status == dhkin::kUsable ? static_cast<long>(stored_) : -1; }
  // Field by field: `solution` was just written that way, and a copy of the whole struct would
  // load it back in wider pieces, which waits until those stores retire.
  void add(const dhkin::Solution& solution) {
    dhkin::Solution& to = stored_ < first_.size() ? first_[stored_] : more_.emplace_back();
    for (int j = 0; j < kDof; ++j) to.q[j] = solution.q[j];
    to.branch = solution.branch;
    to.flags = solution.flags;
    to.error.position = solution.error.position;
    to.error.rotation = solution.error.rotation;
    ++stored_;
  }
  const dhkin::Solution& at(std::size_t i) const {
    return i < first_.size() ? first_[i] : more_[i - first_.size()];
  }

  Output<double> q() const {
    auto out = new_array<double>({count(), static_cast<std::size_t>(kDof)});
    for (std::size_t i = 0; i < count(); ++i) {
      for (int j = 0; j < kDof; ++j) out.data()[kDof * i + j] = at(i).q[j];
    }
    return out;
  }

  Output<std::int16_t> branch() const {
    auto out = new_array<std::int16_t>({count()});
    for (std::size_t i = 0; i < count(); ++i) out.data()[i] = static_cast<std::int16_t>(at(i).branch);
    return out;
  }

  Output<std::uint8_t> flags() const {
    auto out = new_array<std::uint8_t>({count()});
    for (std::size_t i = 0; i < count(); ++i) out.data()[i] = at(i).flags;
    return out;
  }

  Output<double> residuals() const {
    auto out = new_array<double>({count(), 2});
    for (std::size_t i = 0; i < count(); ++i) {
      out.data()[2 * i] = at(i).error.position;
      out.data()[2 * i + 1] = at(i).error.rotation;
    }
    return out;
  }

  // round(q / 2pi) per revolute joint (0 for prismatic ones), as tuples of the solutions'
  // branch index and turns: the key of a configuration.
  nb::list configuration_keys() const {
    nb::list out;
    for (std::size_t i = 0; i < count(); ++i) {
      const dhkin::Solution& s = at(i);
      nb::tuple turns = nb::steal<nb::tuple>(PyTuple_New(kDof));
      for (int j = 0; j < kDof; ++j) {
        const long turn = revolute[j] ? static_cast<long>(std::nearbyint(s.q[j] / dhkin::kTwoPi)) : 0;
        PyTuple_SET_ITEM(turns.ptr(), j, PyLong_FromLong(turn));
      }
      out.append(nb::make_tuple(s.branch, turns));
    }
    return out;
  }

  Output<double> why() const {
    auto out = new_array<double>({static_cast<std::size_t>(dhkin::kWhySize)});
    for (int k = 0; k < dhkin::kWhySize; ++k) out.data()[k] = info.why[k];
    return out;
  }

 private:
  std::array<dhkin::Solution, kBranches> first_{};
  std::vector<dhkin::Solution> more_;
  std::size_t stored_ = 0;
};

// The seed of pose i: row i of (N, 6) seeds, or the one row of (1, 6).
Joints seed_row(const Input<double, nb::shape<-1, kDof>>& seeds, std::size_t i) {
  return joints_of(seeds.data() + kDof * (seeds.shape(0) == 1 ? 0 : i));
}

// A batch call's frames (base_link -> DH frame 0, DH frame n -> TCP) and the solver's plan for
// them (`plan` points into `storage` when the call's TCP is not the table's own).
struct CallPlan {
  CallPlan(const dhkin::ClosedFormSolver& solver, const Input<double, nb::shape<2, 4, 4>>& frames)
      : target(target_frames(frames)), plan(&solver.plan_for(target, storage)) {}
  CallPlan(const CallPlan&) = delete;
  CallPlan& operator=(const CallPlan&) = delete;

  dhkin::TargetFrames target;
  dhkin::Plan storage;
  const dhkin::Plan* plan;
};

// The doubles of a C-contiguous float64 array of `shape` through the buffer protocol, held for
// the view's life. Any other object (another dtype, shape or layout, a list) gives no view
// (`taken()` false, no exception set): ClosedForm::solve then raises a TypeError, as nanobind's
// ndarray caster gives for what it cannot take as it is, and the single call takes its checked
// path, which converts or says what is wrong. A numpy array's buffer costs less than its DLPack
// capsule (nanobind's route: a capsule and two allocations per call, ~5 % of a single call).
class DoublesView {
 public:
  DoublesView(nb::handle array, std::initializer_list<Py_ssize_t> shape) {
    if (PyObject_GetBuffer(array.ptr(), &view_, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0) {
      PyErr_Clear();
      return;
    }
    bool fits = view_.itemsize == sizeof(double) && view_.format != nullptr &&
                native_double(view_.format) && view_.ndim == static_cast<int>(shape.size());
    int k = 0;
    for (Py_ssize_t extent : shape) fits = fits && k < view_.ndim && view_.shape[k++] == extent;
    if (!fits) {
      PyBuffer_Release(&view_);
      return;
    }
    taken_ = true;
  }
  DoublesView(const DoublesView&) = delete;
  DoublesView& operator=(const DoublesView&) = delete;
  ~DoublesView() {
    if (taken_) PyBuffer_Release(&view_);
  }

  bool taken() const { return taken_; }
  const double* data() const { return static_cast<const double*>(view_.buf); }

 private:
  // struct-module format of a native double: "d", or "d" after "@", "=" or the native order
  static bool native_double(const char* format) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    constexpr char kNativeOrder = '>';
#else
    constexpr char kNativeOrder = '<';
#endif
    if (format[0] == '@' || format[0] == '=' || format[0] == kNativeOrder) ++format;
    return format[0] == 'd' && format[1] == '\0';
  }
  Py_buffer view_{};
  bool taken_ = false;
};

// A single call's pose (4, 4) and seed (kDof,) or None, as DoublesViews; taken() where both are
// C-contiguous float64 arrays of those shapes (the seed: or None).
struct PoseAndSeed {
  PoseAndSeed(nb::handle T_array, nb::handle seed_array) : T(T_array, {4, 4}) {
    if (!seed_array.is_none()) seed.emplace(seed_array, std::initializer_list<Py_ssize_t>{kDof});
  }
  bool taken() const { return T.taken() && (!seed || seed->taken()); }
  const double* seed_data() const { return seed ? seed->data() : nullptr; }  // null: zero

  DoublesView T;
  std::optional<DoublesView> seed;
};

// What a single call's result is made of on the Python side: the result type
// (dhkin.ik.result.IKSolutions), the descriptors of the three slots IKSolutions.from_core sets,
// and the values of two of them every result of one solver shares (ClosedForm::bind_results).
struct ResultSlots {
  nb::object type, answer_slot, configure_slot, family_slot, configure, family;
};

// descriptor.__set__(instance, value), as `instance.slot = value` does once it has found the slot
void set_slot(const nb::object& descriptor, nb::handle instance, nb::handle value) {
  if (Py_TYPE(descriptor.ptr())->tp_descr_set(descriptor.ptr(), instance.ptr(), value.ptr()) != 0) {
    throw nb::python_error();
  }
}

class ClosedForm {
 public:
  ClosedForm(const nb::dict& plan, Input<double, nb::shape<2, 4, 4>> frames)
      : solver_(make_plan(plan), target_frames(frames)),
        default_plan_(&solver_.plan_for(solver_.default_frames(), unused_)) {}

  // One pose (4 x 4, base_link -> tool0, or -> the TCP of `frames`): its Answer. Without a
  // seed the seed is zero; without frames, the table's own base and tool.
  // T (4, 4) and the seed (kDof,) are C-contiguous float64 arrays (DoublesView), else TypeError.
  Answer solve(nb::handle T_array, nb::handle seed_array, double tolerance,
               std::optional<Input<double, nb::shape<2, 4, 4>>> frames, bool copies) const {
    const PoseAndSeed in(T_array, seed_array);
    if (!in.taken()) {
      throw nb::type_error("expected C-contiguous float64 arrays of the call's shapes");
    }
    if (!frames) return answer_of(in.T.data(), in.seed_data(), tolerance, nullptr, copies);
    const dhkin::TargetFrames targets = target_frames(*frames);
    return answer_of(in.T.data(), in.seed_data(), tolerance, &targets, copies);
  }

  // Binds what solve_common makes its results of: the type IKSolutions, whose slots "_answer",
  // "_configure" and "_family" it sets to the call's Answer and to `configure` and `family`.
  void bind_results(nb::object type, nb::object configure, nb::object family) {
    if (!PyType_Check(type.ptr())) throw nb::type_error("bind_results: expected a type");
    results_ = ResultSlots{type, nb::getattr(type, "_answer"), nb::getattr(type, "_configure"),
                           nb::getattr(type, "_family"), std::move(configure), std::move(family)};
    for (const nb::object* slot : {&results_->answer_slot, &results_->configure_slot,
                                   &results_->family_slot}) {
      if (Py_TYPE(slot->ptr())->tp_descr_set == nullptr) {
        throw nb::type_error("bind_results: expected slots _answer, _configure and _family");
      }
    }
  }

  // dhkin.ik.solver.ClosedFormSolver.solve_one's common call made whole here: no TCP, `copies` a
  // bool, `tolerance` a finite positive float, T and the seed (or None) arrays solve takes as
  // they are. Its result when the pose has solutions: an IKSolutions (bind_results) holding the
  // Answer, as IKSolutions.from_core makes it; the Answer when the usable pose has none (the
  // caller says why); None for any other call (the caller's checked path converts, or raises the
  // error that names the input).
  nb::object solve_common(nb::handle T_array, nb::handle seed_array, nb::handle tolerance,
                          nb::handle tcp, nb::handle copies) const {
    if (!results_ || !tcp.is_none() || !(copies.is(Py_True) || copies.is(Py_False)) ||
        !PyFloat_CheckExact(tolerance.ptr())) {
      return nb::none();
    }
    const double tol = PyFloat_AS_DOUBLE(tolerance.ptr());
    if (!(0.0 < tol && tol < INFINITY)) return nb::none();
    const PoseAndSeed in(T_array, seed_array);
    if (!in.taken()) return nb::none();
    Answer answer = answer_of(in.T.data(), in.seed_data(), tol, nullptr, copies.is(Py_True));
    const long found = answer.found();
    if (found < 0) return nb::none();
    nb::object held = nb::cast(std::move(answer));
    if (found == 0) return held;
    PyTypeObject* type = reinterpret_cast<PyTypeObject*>(results_->type.ptr());
    nb::object result = nb::steal(type->tp_alloc(type, 0));  // object.__new__(IKSolutions)
    if (!result.is_valid()) throw nb::python_error();
    set_slot(results_->answer_slot, result, held);
    set_slot(results_->configure_slot, result, results_->configure);
    set_slot(results_->family_slot, result, results_->family);
    return result;
  }

  // Steps 1-3 of N poses into q (N, 8, 6), ok, flags (N, 8), errors (N, 8, 2), totals (N, 8)
  // (solutions step 4 can give per branch, the roots beyond the slots counted with their branch),
  // why (N, 6) and info (N, 7: status, projection, candidates, verified, dropped, best position,
  // best rotation), and the roots beyond the slots (extra_roots.hpp) into extra_q (N, E, 6),
  // extra_branch (-1 past the pose's last), extra_flags (N, E) and extra_errors (N, E, 2); E may
  // be 0 for a table without exact roots, else at least EXTRA_ROOTS. Seeds: (N, 6) or (1, 6).
  // `direct` false skips the direct path (every pose through the full pipeline: for tests).
  void principal(Input<double, nb::shape<-1, 4, 4>> targets, Input<double, nb::shape<-1, kDof>> seeds,
                 double tolerance, Input<double, nb::shape<2, 4, 4>> frames, bool copies,
                 Output<double, nb::shape<-1, kBranches, kDof>> q,
                 Output<bool, nb::shape<-1, kBranches>> ok,
                 Output<std::uint8_t, nb::shape<-1, kBranches>> flags,
                 Output<double, nb::shape<-1, kBranches, 2>> errors,
                 Output<std::int64_t, nb::shape<-1, kBranches>> totals,
                 Output<double, nb::shape<-1, dhkin::kWhySize>> why,
                 Output<double, nb::shape<-1, 7>> info,
                 Output<double, nb::shape<-1, -1, kDof>> extra_q,
                 Output<std::int16_t, nb::ndim<2>> extra_branch,
                 Output<std::uint8_t, nb::ndim<2>> extra_flags,
                 Output<double, nb::shape<-1, -1, 2>> extra_errors, bool direct) {
    check_rows(targets.shape(0), seeds.shape(0),
               {q.shape(0), ok.shape(0), flags.shape(0), errors.shape(0), totals.shape(0),
                why.shape(0), info.shape(0), extra_q.shape(0), extra_branch.shape(0),
                extra_flags.shape(0), extra_errors.shape(0)});
    const std::size_t room = extra_q.shape(1);
    if (extra_branch.shape(1) != room || extra_flags.shape(1) != room ||
        extra_errors.shape(1) != room) {
      throw std::invalid_argument("principal: the extra roots' arrays differ in width");
    }
    if (solver_.plan().exact_roots != nullptr &&
        room < static_cast<std::size_t>(dhkin::ExtraRoots::kCapacity)) {
      throw std::invalid_argument("principal: room for every root beyond the slots needed");
    }
    for_each_pose(targets, seeds, frames, [&](std::size_t i, const dhkin::Plan& plan,
                                              const dhkin::TargetFrames& target, const double* T,
                                              const Joints& seed) {
      dhkin::Branches branches;
      dhkin::PoseInfo pose;
      if (direct) {
        dhkin::solve_pose(plan, target, T, seed, tolerance, branches, pose);
      } else {  // the pipeline itself (no direct path of either kind), then the roots beyond
                // the slots as every pose that leaves the direct paths gets them
        dhkin::pipeline_branches(plan, target, T, seed, tolerance, branches, pose);
        dhkin::add_roots_beyond_slots(plan, target, T, seed, tolerance, pose, branches);
      }
      const auto counts = dhkin::copy_totals(plan, branches, tolerance, copies);
      for (int b = 0; b < kBranches; ++b) {
        for (int j = 0; j < kDof; ++j) q(i, b, j) = branches.q[b][j];
        ok(i, b) = branches.ok[b];
        flags(i, b) = branches.flags[b];
        errors(i, b, 0) = branches.errors[b].position;
        errors(i, b, 1) = branches.errors[b].rotation;
        totals(i, b) = counts[b];
      }
      for (std::size_t k = 0; k < room; ++k) {  // the roots beyond the slots, then empty rows
        const bool found = static_cast<int>(k) < branches.extra.count;
        for (int j = 0; j < kDof; ++j) extra_q(i, k, j) = found ? branches.extra.q[k][j] : 0.0;
        extra_branch(i, k) = static_cast<std::int16_t>(found ? branches.extra.branch[k] : -1);
        extra_flags(i, k) = found ? branches.extra.flags[k] : 0;
        extra_errors(i, k, 0) = found ? branches.extra.errors[k].position : 0.0;
        extra_errors(i, k, 1) = found ? branches.extra.errors[k].rotation : 0.0;
      }
      for (int k = 0; k < dhkin::kWhySize; ++k) why(i, k) = pose.why[k];
      write_info(pose, &info(i, 0));
    });
  }

  // N poses without copies (one solution per branch, its in-limit copy nearest the seed)
  // straight into the result arrays q (N, 8, 6), valid, branch, flags (N, 8), errors (N, 8, 2),
  // projection and dropped (N): expand(copies = false) after principal(), pose by pose, bit for
  // bit. Slots without a solution are left as given. Returns (index of the first pose whose
  // status is not usable or -1, its status, the most solutions of any pose); poses after a
  // rejected one are not solved.
  std::tuple<long, int, int> nearest(
      Input<double, nb::shape<-1, 4, 4>> targets, Input<double, nb::shape<-1, kDof>> seeds,
      double tolerance, Input<double, nb::shape<2, 4, 4>> frames,
      Output<double, nb::shape<-1, kBranches, kDof>> q, Output<bool, nb::shape<-1, kBranches>> valid,
      Output<std::int16_t, nb::shape<-1, kBranches>> branch,
      Output<std::uint8_t, nb::shape<-1, kBranches>> flags,
      Output<double, nb::shape<-1, kBranches, 2>> errors, Output<double, nb::ndim<1>> projection,
      Output<std::int64_t, nb::ndim<1>> dropped) {
    const std::size_t n = targets.shape(0);
    check_rows(n, seeds.shape(0), {q.shape(0), valid.shape(0), branch.shape(0), flags.shape(0),
                                   errors.shape(0), projection.shape(0), dropped.shape(0)});
    if (solver_.plan().exact_roots != nullptr) {
      throw std::logic_error("nearest: a table with exact roots answers beyond the slots: rows()");
    }
    const CallPlan call(solver_, frames);
    const dhkin::TargetFrames& target = call.target;
    const dhkin::Plan& plan = *call.plan;
    const dhkin::NearestOutputs out{q.data(), valid.data(), branch.data(), flags.data(),
                                    errors.data(), projection.data(), dropped.data()};
    nb::gil_scoped_release release;
    const dhkin::BatchReport report =
        dhkin::solve_nearest(plan, target, targets.data(), n, seeds.data(),
                             seeds.shape(0) == 1 ? 0 : kDof, tolerance, out);
    return {report.rejected, report.status, report.width};
  }

  // Completes a refined table's answers with the roots beyond its branch slots
  // (dhkin/extra_roots.hpp): `general`, the table's dhkin._core.General6R, gives them.
  void attach_exact_roots(nb::handle general) {
    if (!solver_.plan().refine) {
      throw std::invalid_argument("exact roots: the table is an exact family member (no slots to "
                                  "complete)");
    }
    solver_.attach_exact_roots(dhkin::bindings::exact_roots_of(general));
  }

  // N poses as rows (dhkin/rows.hpp): (q (R, 6), branch (R,), flags (R,), errors (R, 2)),
  // counts, projection and dropped (per pose answered), the first rejected pose or -1, its
  // status. Every table; the batch of one whose answers reach beyond the slots.
  nb::tuple rows(Input<double, nb::shape<-1, 4, 4>> targets, Input<double, nb::shape<-1, kDof>> seeds,
                 double tolerance, Input<double, nb::shape<2, 4, 4>> frames, bool copies) {
    const std::size_t n = targets.shape(0);
    check_rows(n, seeds.shape(0), {});
    const CallPlan call(solver_, frames);
    dhkin::RowsAnswer out;
    {
      nb::gil_scoped_release release;
      out = dhkin::solve_rows(*call.plan, call.target, targets.data(), n, seeds.data(),
                              seeds.shape(0) == 1 ? 0 : kDof, tolerance, copies);
    }
    const std::size_t r = out.rows.size(), answered = out.counts.size();
    auto q = new_array<double>({r, static_cast<std::size_t>(kDof)});
    auto branch = new_array<std::int16_t>({r});
    auto flags = new_array<std::uint8_t>({r});
    auto errors = new_array<double>({r, 2});
    for (std::size_t k = 0; k < r; ++k) {
      const dhkin::Solution& s = out.rows[k];
      for (int j = 0; j < kDof; ++j) q.data()[kDof * k + j] = s.q[j];
      branch.data()[k] = static_cast<std::int16_t>(s.branch);
      flags.data()[k] = s.flags;
      errors.data()[2 * k] = s.error.position;
      errors.data()[2 * k + 1] = s.error.rotation;
    }
    auto counts = new_array<std::int64_t>({answered});
    auto projection = new_array<double>({answered});
    auto dropped = new_array<std::int64_t>({answered});
    for (std::size_t i = 0; i < answered; ++i) {
      counts.data()[i] = out.counts[i];
      projection.data()[i] = out.projection[i];
      dropped.data()[i] = out.dropped[i];
    }
    return nb::make_tuple(q, branch, flags, errors, counts, projection, dropped, out.rejected,
                          out.status);
  }

  // Whether the direct path answers each of N poses (the rest take the full pipeline); with
  // `direct` false, principal() skips the direct path (tests compare the two answers).
  void direct_answers(Input<double, nb::shape<-1, 4, 4>> targets, Input<double, nb::shape<-1, kDof>> seeds,
                      double tolerance, Input<double, nb::shape<2, 4, 4>> frames,
                      Output<bool, nb::ndim<1>> answered) {
    answered_by(
        [](auto&&... arguments) { return dhkin::direct_branches(arguments...); },
        targets, seeds, tolerance, frames, answered);
  }

  // Whether the refined direct path (refined_direct.hpp) answers each of N poses of a refined
  // table (the rest take the pipeline; false for every pose of an exact-family table): which
  // poses scripts/check_refined.py counts as settled by it.
  void refined_direct_answers(Input<double, nb::shape<-1, 4, 4>> targets,
                              Input<double, nb::shape<-1, kDof>> seeds, double tolerance,
                              Input<double, nb::shape<2, 4, 4>> frames,
                              Output<bool, nb::ndim<1>> answered) {
    answered_by(
        [](auto&&... arguments) { return dhkin::direct_refined_branches(arguments...); },
        targets, seeds, tolerance, frames, answered);
  }

  // Step 4 of N poses from principal()'s outputs into out_q (N, M, 6), out_valid, out_branch,
  // out_flags (N, M) and out_errors (N, M, 2); M must hold every pose's solutions.
  void expand(Input<double, nb::shape<-1, 4, 4>> targets, Input<double, nb::shape<-1, kDof>> seeds,
              double tolerance, Input<double, nb::shape<2, 4, 4>> frames, bool copies,
              Input<double, nb::shape<-1, kBranches, kDof>> q, Input<bool, nb::shape<-1, kBranches>> ok,
              Input<std::uint8_t, nb::shape<-1, kBranches>> flags,
              Input<double, nb::shape<-1, kBranches, 2>> errors,
              Output<double, nb::shape<-1, -1, kDof>> out_q, Output<bool, nb::ndim<2>> out_valid,
              Output<std::int16_t, nb::ndim<2>> out_branch, Output<std::uint8_t, nb::ndim<2>> out_flags,
              Output<double, nb::shape<-1, -1, 2>> out_errors) {
    const std::size_t n = targets.shape(0);
    check_rows(n, seeds.shape(0), {q.shape(0), ok.shape(0), flags.shape(0), errors.shape(0),
                                   out_q.shape(0), out_valid.shape(0), out_branch.shape(0),
                                   out_flags.shape(0), out_errors.shape(0)});
    const std::size_t width = out_q.shape(1);
    if (out_valid.shape(1) != width || out_branch.shape(1) != width ||
        out_flags.shape(1) != width || out_errors.shape(1) != width) {
      throw std::invalid_argument("expand: output arrays differ in width");
    }
    const CallPlan call(solver_, frames);
    const dhkin::TargetFrames& target = call.target;
    const dhkin::Plan& plan = *call.plan;
    bool overflow = false;
    {
      nb::gil_scoped_release release;
      for (std::size_t i = 0; i < n && !overflow; ++i) {
        const Joints seed = seed_row(seeds, i);
        dhkin::Branches branches;
        for (int b = 0; b < kBranches; ++b) {
          branches.q[b] = joints_of(&q(i, b, 0));
          branches.ok[b] = ok(i, b);
          branches.flags[b] = flags(i, b);
          branches.errors[b] = {errors(i, b, 0), errors(i, b, 1)};
        }
        std::size_t slot = 0;
        const long count = dhkin::expand(
            plan, target, targets.data() + 16 * i, seed, tolerance, copies, branches,
            [&](const dhkin::Solution& s) {
              if (slot >= width) return false;
              for (int j = 0; j < kDof; ++j) out_q(i, slot, j) = s.q[j];
              out_branch(i, slot) = static_cast<std::int16_t>(s.branch);
              out_flags(i, slot) = s.flags;
              out_errors(i, slot, 0) = s.error.position;
              out_errors(i, slot, 1) = s.error.rotation;
              ++slot;
              return true;
            });
        overflow = count < 0;
        for (std::size_t k = 0; k < width; ++k) {
          out_valid(i, k) = k < slot;
          if (k >= slot) {
            out_branch(i, k) = -1;
            out_flags(i, k) = 0;
            for (int j = 0; j < kDof; ++j) out_q(i, k, j) = 0.0;
            out_errors(i, k, 0) = out_errors(i, k, 1) = 0.0;
          }
        }
      }
    }
    if (overflow) throw std::length_error("IK expansion: more solutions than counted");
  }

 private:
  // answered(i): whether `path` (a direct path: plan, target frames, pose, seed, tolerance,
  // branches, pose info -> settled) answers pose i of N on its own.
  template <typename Path>
  void answered_by(Path path, Input<double, nb::shape<-1, 4, 4>> targets,
                   Input<double, nb::shape<-1, kDof>> seeds, double tolerance,
                   Input<double, nb::shape<2, 4, 4>> frames, Output<bool, nb::ndim<1>> answered) {
    check_rows(targets.shape(0), seeds.shape(0), {answered.shape(0)});
    for_each_pose(targets, seeds, frames, [&](std::size_t i, const dhkin::Plan& plan,
                                              const dhkin::TargetFrames& target, const double* T,
                                              const Joints& seed) {
      dhkin::Branches branches;
      dhkin::PoseInfo pose;
      answered(i) = path(plan, target, T, seed, tolerance, branches, pose);
    });
  }

  // body(i, plan, target frames, pose i's 4 x 4 row-major numbers, its seed) for each of the N
  // poses, with the call's plan (the TCP's own where `frames` give one) and the GIL released.
  template <typename Body>
  void for_each_pose(Input<double, nb::shape<-1, 4, 4>> targets,
                     Input<double, nb::shape<-1, kDof>> seeds,
                     Input<double, nb::shape<2, 4, 4>> frames, Body body) {
    const CallPlan call(solver_, frames);
    nb::gil_scoped_release release;
    for (std::size_t i = 0; i < targets.shape(0); ++i) {
      body(i, *call.plan, call.target, targets.data() + 16 * i, seed_row(seeds, i));
    }
  }

  // solve's work on checked inputs: `frames` null for the table's own base and tool, `seed` null
  // for zero.
  Answer answer_of(const double* T, const double* seed, double tolerance,
                   const dhkin::TargetFrames* frames, bool copies) const {
    const dhkin::TargetFrames targets = frames ? *frames : solver_.default_frames();
    std::unique_ptr<dhkin::Plan> storage;  // the plan of a TCP of the call's own
    const dhkin::Plan* plan = default_plan_;
    if (frames) {
      storage = std::make_unique<dhkin::Plan>();
      plan = &solver_.plan_for(targets, *storage);
    }
    const Joints seed_q = seed ? joints_of(seed) : Joints{};
    Answer answer;
    for (int j = 0; j < kDof; ++j) answer.revolute[j] = plan->revolute(j);
    dhkin::Branches branches;
    // solve_pose: the direct path, else the pipeline (which can take long: the GIL is released)
    if (!dhkin::direct_branches(*plan, targets, T, seed_q, tolerance, branches, answer.info)) {
      nb::gil_scoped_release release;
      dhkin::solve_branches(*plan, targets, T, seed_q, tolerance, branches, answer.info);
    }
    if (answer.info.status == dhkin::kUsable) {
      dhkin::expand(*plan, targets, T, seed_q, tolerance, copies, branches,
                    [&](const dhkin::Solution& s) {
                      answer.add(s);
                      return true;
                    });
    }
    return answer;
  }

  static void check_rows(std::size_t n, std::size_t seeds, std::initializer_list<std::size_t> rows) {
    if (seeds != 1 && seeds != n) throw std::invalid_argument("seeds: expected 1 or N rows");
    for (std::size_t r : rows) {
      if (r != n) throw std::invalid_argument("arrays differ in their number of poses");
    }
  }

  static void write_info(const dhkin::PoseInfo& pose, double* out) {
    out[0] = pose.status, out[1] = pose.projection, out[2] = pose.candidates;
    out[3] = pose.verified, out[4] = pose.dropped, out[5] = pose.best_position;
    out[6] = pose.best_rotation;
  }

  dhkin::ClosedFormSolver solver_;
  dhkin::Plan unused_;                // plan_for's storage for the default frames: never written
  const dhkin::Plan* default_plan_;   // the plan of the table's own base and tool
  std::optional<ResultSlots> results_;  // bind_results: what solve_common's results are made of
};

// ---- chains ----------------------------------------------------------------------------------

class ChainModel {
 public:
  ChainModel(Input<double, nb::shape<-1, 4, 4>> before, Input<bool, nb::ndim<1>> revolute,
             Input<double, nb::ndim<1>> direction, Input<double, nb::ndim<1>> offset,
             Input<double, nb::shape<4, 4>> tail)
      : chain_(make_chain(before, revolute, direction, offset, tail)) {}

  int dof() const { return chain_.dof(); }

  // FK of N joint vectors (N, n) into out (N, 4, 4): DH frame 0 -> the chain's tail.
  void fk(Input<double, nb::ndim<2>> q, Output<double, nb::shape<-1, 4, 4>> out) const {
    const std::size_t n = q.shape(0);
    if (q.shape(1) != static_cast<std::size_t>(chain_.dof()) || out.shape(0) != n) {
      throw std::invalid_argument("fk: expected q (N, dof) and out (N, 4, 4)");
    }
    nb::gil_scoped_release release;
    for (std::size_t i = 0; i < n; ++i) {
      const Frame T = dhkin::fk(chain_, q.data() + chain_.dof() * i);
      double* o = out.data() + 16 * i;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) o[4 * r + c] = T.R[r][c];
        o[4 * r + 3] = T.p[r];
      }
      o[12] = o[13] = o[14] = 0.0;
      o[15] = 1.0;
    }
  }

  // Newton on the chain (refine(), newton.hpp) from each row of q (N, 6; in place, each row ends
  // as its best iterate) towards its target (N, 4, 4: DH frame 0 -> the chain's tail), joints
  // `fixed` held, with refine()'s settings; errors (N, 2) receives each row's position and
  // rotation error. With `lanes`, the rows go kLanes at a time through refine_lanes_exact (the
  // last group's spare lanes inactive), which gives each row the bits refine() gives it alone:
  // the two roads exist side by side so that tests can hold them to that.
  void refine(Output<double, nb::ndim<2>> q, Input<double, nb::shape<-1, 4, 4>> targets,
              Input<bool, nb::shape<dhkin::kDof>> fixed, double tolerance, int budget,
              double growth, double damping_start, bool stop_on_stall, bool lanes,
              Output<double, nb::shape<-1, 2>> errors) const {
    using dhkin::kDof;
    using dhkin::kLanes;
    const std::size_t n = q.shape(0);
    if (chain_.dof() != kDof || q.shape(1) != static_cast<std::size_t>(kDof) ||
        targets.shape(0) != n || errors.shape(0) != n) {
      throw std::invalid_argument("refine: expected a chain of 6 joints, q (N, 6), targets "
                                  "(N, 4, 4) and errors (N, 2)");
    }
    dhkin::JointMask held{};
    for (int j = 0; j < kDof; ++j) held[j] = fixed.data()[j];
    const dhkin::newton::Settings settings{budget, growth, damping_start, stop_on_stall};
    const dhkin::ChainShape shape(chain_);
    nb::gil_scoped_release release;
    double* rows = q.data();
    if (!lanes) {
      for (std::size_t i = 0; i < n; ++i) {
        dhkin::Joints row;
        std::memcpy(row.data(), rows + kDof * i, sizeof row);
        const dhkin::PoseError error = dhkin::refine(
            chain_, dhkin::raw_frame(targets.data() + 16 * i), row, held, tolerance, settings);
        std::memcpy(rows + kDof * i, row.data(), sizeof row);
        errors.data()[2 * i] = error.position;
        errors.data()[2 * i + 1] = error.rotation;
      }
      return;
    }
    // one target for every lane of a group: refine_lanes_exact takes one, so each group holds
    // the rows of one target (rows with another target start a new group)
    std::size_t first = 0;
    while (first < n) {
      std::size_t end = first + 1;
      const double* target = targets.data() + 16 * first;
      while (end < n && end - first < static_cast<std::size_t>(kLanes) &&
             std::memcmp(targets.data() + 16 * end, target, 16 * sizeof(double)) == 0) {
        ++end;
      }
      dhkin::JointsT<dhkin::Lanes> starts;
      dhkin::Mask active = dhkin::uniform(false);
      for (int l = 0; l < kLanes; ++l) {
        const std::size_t row = l < static_cast<int>(end - first) ? first + l : first;
        for (int j = 0; j < kDof; ++j) dhkin::set_lane(starts[j], l, rows[kDof * row + j]);
        dhkin::set_lane(active, l, row == first + l);
      }
      const dhkin::PoseErrorT<dhkin::Lanes> error = dhkin::refine_lanes_exact(
          chain_, shape, dhkin::raw_frame(target), starts, held, tolerance, settings, active);
      for (std::size_t i = first; i < end; ++i) {
        const int l = static_cast<int>(i - first);
        for (int j = 0; j < kDof; ++j) rows[kDof * i + j] = dhkin::lane(starts[j], l);
        errors.data()[2 * i] = dhkin::lane(error.position, l);
        errors.data()[2 * i + 1] = dhkin::lane(error.rotation, l);
      }
      first = end;
    }
  }

 private:
  dhkin::Chain chain_;
};

}  // namespace

// The general 6R solver's bindings (cpp/bindings_general6r.cpp).
void bind_general6r(nb::module_& m);
// The numerical IK's bindings (cpp/bindings_numerical.cpp).
void bind_numerical(nb::module_& m);

NB_MODULE(_core, m) {
  bind_general6r(m);
  bind_numerical(m);
  m.doc() = "dhkin's compiled core: chains, the closed-form IK pipeline (see cpp/dhkin/*.hpp).";
  m.attr("BRANCHES") = kBranches;
  m.attr("WHY_SIZE") = dhkin::kWhySize;
  m.attr("EXTRA_ROOTS") = dhkin::ExtraRoots::kCapacity;
  m.attr("ORTHONORMALITY_GATE") = dhkin::kOrthonormalityGate;
  m.attr("BOTTOM_ROW_TOLERANCE") = dhkin::kBottomRowTolerance;
  m.attr("FLAG_BAND") = dhkin::kFlagBand;
  m.attr("MERGE_ANGLE") = dhkin::kMergeAngle;
  m.attr("FK_ROUNDING") = dhkin::kFkRounding;
  // doubles per vector register the core was built for (cpp/dhkin/simd.hpp): 8 with AVX-512, 4
  // with AVX, 2 otherwise (the portable build); the lanes' speed, and the last bits of Eigen's
  // kernels, follow it
  m.attr("VECTOR_WIDTH") = dhkin::simd::kNative;

  m.def("pose_status", [](Input<double, nb::shape<4, 4>> T) { return static_cast<int>(dhkin::pose_status(T.data())); },
        "T"_a, "0 for a usable pose (4, 4), else why not (1 not finite, 2 bottom row, 3 not a rotation).");
  m.def("project",
        [](Input<double, nb::shape<4, 4>> T) {
          double moved = 0.0;
          const Frame f = dhkin::projected_frame(T.data(), moved);
          auto out = new_array<double>({4, 4});
          for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) out.data()[4 * r + c] = f.R[r][c];
            out.data()[4 * r + 3] = f.p[r];
          }
          out.data()[15] = 1.0;
          return nb::make_tuple(out, moved);
        },
        "T"_a, "(T with its rotation block projected onto the nearest rotation, Frobenius norm of the change).");

  // The elementary functions of the core, elementwise, for the tests to measure (angles.hpp).
  m.def("sincos",
        [](Input<double, nb::ndim<1>> x) {
          auto out = new_array<double>({x.shape(0), 2});
          for (std::size_t i = 0; i < x.shape(0); ++i) {
            const dhkin::SinCos t = dhkin::sincos(x(i));
            out.data()[2 * i] = t.s, out.data()[2 * i + 1] = t.c;
          }
          return out;
        },
        "x"_a, "(sin x, cos x) per element (N, 2).");
  m.def("atan2",
        [](Input<double, nb::ndim<1>> y, Input<double, nb::ndim<1>> x) {
          if (y.shape(0) != x.shape(0)) throw std::invalid_argument("atan2: y and x differ in length");
          auto out = new_array<double>({x.shape(0)});
          for (std::size_t i = 0; i < x.shape(0); ++i) out.data()[i] = dhkin::atan2(y(i), x(i));
          return out;
        },
        "y"_a, "x"_a, "atan2(y, x) per element.");
  m.def("wrap",
        [](Input<double, nb::ndim<1>> x) {
          auto out = new_array<double>({x.shape(0)});
          for (std::size_t i = 0; i < x.shape(0); ++i) out.data()[i] = dhkin::wrap(x(i));
          return out;
        },
        "x"_a, "x wrapped to (-pi, pi] per element.");

  m.def("right_svd",
        [](Input<double, nb::shape<6, 6>> A, std::optional<Input<double, nb::shape<6, 6>>> start) {
          dhkin::Matrix6 matrix, start_V;
          for (int r = 0; r < 6; ++r) {
            for (int c = 0; c < 6; ++c) {
              matrix(r, c) = A(r, c);
              if (start) start_V(r, c) = (*start)(r, c);
            }
          }
          const dhkin::RightSvd svd = start ? dhkin::right_svd(matrix, start_V) : dhkin::right_svd(matrix);
          auto values = new_array<double>({6});
          auto V = new_array<double>({6, 6});
          auto AV = new_array<double>({6, 6});
          for (int r = 0; r < 6; ++r) {
            values.data()[r] = svd.values(r);
            for (int c = 0; c < 6; ++c) {
              V.data()[6 * r + c] = svd.V(r, c);
              AV.data()[6 * r + c] = svd.AV(r, c);
            }
          }
          return nb::make_tuple(values, V, AV);
        },
        "A"_a, "start"_a = nb::none(),
        "(singular values largest first, V, A V) of a 6 x 6 matrix by one-sided Jacobi (right_svd.hpp), from the orthogonal `start` if given.");

  nb::class_<ChainModel>(m, "Chain")
      .def(nb::init<Input<double, nb::shape<-1, 4, 4>>, Input<bool, nb::ndim<1>>,
                    Input<double, nb::ndim<1>>, Input<double, nb::ndim<1>>,
                    Input<double, nb::shape<4, 4>>>(),
           "before"_a, "revolute"_a, "direction"_a, "offset"_a, "tail"_a)
      .def_prop_ro("dof", &ChainModel::dof)
      .def("fk", &ChainModel::fk, "q"_a, "out"_a)
      .def("refine", &ChainModel::refine, "q"_a, "targets"_a, "fixed"_a, "tolerance"_a,
           "budget"_a, "growth"_a, "damping_start"_a, "stop_on_stall"_a, "lanes"_a, "errors"_a);

  // pooled: a dropped Answer's Python object is kept for the next one (no allocation, no entry in
  // nanobind's instance map per single call)
  nb::class_<Answer>(m, "Answer", nb::pooled())
      .def_prop_ro("count", &Answer::count)
      .def_prop_ro("found", &Answer::found)
      .def_prop_ro("status", [](const Answer& a) { return a.info.status; })
      .def_prop_ro("projection", [](const Answer& a) { return a.info.projection; })
      .def_prop_ro("candidates", [](const Answer& a) { return a.info.candidates; })
      .def_prop_ro("verified", [](const Answer& a) { return a.info.verified; })
      .def_prop_ro("dropped", [](const Answer& a) { return a.info.dropped; })
      .def_prop_ro("best_position", [](const Answer& a) { return a.info.best_position; })
      .def_prop_ro("best_rotation", [](const Answer& a) { return a.info.best_rotation; })
      .def("q", &Answer::q)
      .def("branch", &Answer::branch)
      .def("flags", &Answer::flags)
      .def("residuals", &Answer::residuals)
      .def("configuration_keys", &Answer::configuration_keys)
      .def("why", &Answer::why);

  nb::class_<ClosedForm>(m, "ClosedForm")
      .def(nb::init<const nb::dict&, Input<double, nb::shape<2, 4, 4>>>(), "plan"_a, "frames"_a)
      .def("solve", &ClosedForm::solve, "T"_a, "seed"_a.none(), "tolerance"_a,
           "frames"_a.none(), "copies"_a)
      .def("bind_results", &ClosedForm::bind_results, "type"_a, "configure"_a, "family"_a)
      .def("solve_common", &ClosedForm::solve_common, "T"_a.none(), "seed"_a.none(),
           "tolerance"_a.none(), "tcp"_a.none(), "copies"_a.none())
      .def("principal", &ClosedForm::principal, "targets"_a, "seeds"_a, "tolerance"_a,
           "frames"_a, "copies"_a, "q"_a, "ok"_a, "flags"_a, "errors"_a, "totals"_a, "why"_a,
           "info"_a, "extra_q"_a, "extra_branch"_a, "extra_flags"_a, "extra_errors"_a,
           "direct"_a = true)
      .def("nearest", &ClosedForm::nearest, "targets"_a, "seeds"_a, "tolerance"_a, "frames"_a,
           "q"_a, "valid"_a, "branch"_a, "flags"_a, "errors"_a, "projection"_a, "dropped"_a)
      .def("direct_answers", &ClosedForm::direct_answers, "targets"_a, "seeds"_a,
           "tolerance"_a, "frames"_a, "answered"_a)
      .def("refined_direct_answers", &ClosedForm::refined_direct_answers, "targets"_a,
           "seeds"_a, "tolerance"_a, "frames"_a, "answered"_a)
      .def("attach_exact_roots", &ClosedForm::attach_exact_roots, "general"_a)
      .def("rows", &ClosedForm::rows, "targets"_a, "seeds"_a, "tolerance"_a, "frames"_a,
           "copies"_a)
      .def("expand", &ClosedForm::expand, "targets"_a, "seeds"_a, "tolerance"_a, "frames"_a,
           "copies"_a, "q"_a, "ok"_a, "flags"_a, "errors"_a, "out_q"_a, "out_valid"_a,
           "out_branch"_a, "out_flags"_a, "out_errors"_a);
}
