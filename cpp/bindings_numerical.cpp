// dhkin._core's numerical IK: the descent of one start (cpp/dhkin/numerical/descent.hpp) on a
// chain of 1 to 32 joints, for dhkin.ik.numerical. Python keeps the settings' checks, the tasks'
// set-up, the starts, the choice among converged starts and the Pinocchio check of each answer.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>

#include <optional>
#include <stdexcept>
#include <string>

#include "array_io.hpp"
#include "dhkin/numerical/descent.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

namespace numerical = dhkin::numerical;

using dhkin::raw_frame;
using dhkin::bindings::Input;
using dhkin::bindings::make_chain;
using dhkin::bindings::Output;

numerical::JointVector joint_vector(Input<double, nb::ndim<1>> values, int dof, const char* name) {
  if (values.shape(0) != static_cast<std::size_t>(dof)) {
    throw std::invalid_argument(std::string(name) + ": expected " + std::to_string(dof) +
                                " joint values");
  }
  numerical::JointVector out(dof);
  for (int j = 0; j < dof; ++j) out[j] = values(j);
  return out;
}

// A task of the descent (numerical::Task), built once per solve.
struct NumericalTask {
  numerical::Task task;
};

NumericalTask make_task(bool pose, int rows, Input<double, nb::shape<4, 4>> target_inverse,
                        Input<double, nb::shape<3>> world_point,
                        std::optional<Input<double, nb::shape<3, 3>>> base_rotation_t,
                        std::optional<Input<double, nb::shape<3>>> tcp,
                        std::optional<Input<double, nb::ndim<1>>> preferred,
                        std::optional<Input<double, nb::ndim<1>>> weights) {
  if (pose ? rows != 6 : rows != 2 && rows != 3) {
    throw std::invalid_argument("task: expected 6 rows for a pose, 2 or 3 for a position");
  }
  if (preferred.has_value() != weights.has_value()) {
    throw std::invalid_argument("task: preferred and weights go together");
  }
  NumericalTask out;
  numerical::Task& t = out.task;
  t.pose = pose, t.rows = rows;
  t.target_inverse = raw_frame(target_inverse.data());
  t.world_point = {world_point(0), world_point(1), world_point(2)};
  if (base_rotation_t) {
    t.to_base = true;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) t.base_rotation_t.m[r][c] = (*base_rotation_t)(r, c);
    }
  }
  if (tcp) t.has_tcp = true, t.tcp = {(*tcp)(0), (*tcp)(1), (*tcp)(2)};
  if (preferred) {
    const int n = static_cast<int>(preferred->shape(0));
    t.slides = true;
    t.preferred = joint_vector(*preferred, n, "preferred");
    t.weights = joint_vector(*weights, n, "weights");
  }
  return out;
}

// The settings of the descent (numerical::Settings), built once per SolverSettings.
struct NumericalSettings {
  numerical::Settings settings;
};

NumericalSettings make_settings(const std::string& method, double tolerance, int max_iterations,
                                double damping, double nullspace_gain, double nullspace_tolerance,
                                int slide_iterations, int stall_window, double stall_ratio) {
  NumericalSettings out;
  numerical::Settings& s = out.settings;
  if (method == "lm") {
    s.method = numerical::Method::kLevenbergMarquardt;
  } else if (method == "dls") {
    s.method = numerical::Method::kDampedLeastSquares;
  } else if (method == "newton") {
    s.method = numerical::Method::kNewton;
  } else {
    throw std::invalid_argument("settings: method must be 'lm', 'dls' or 'newton'");
  }
  s.tolerance = tolerance, s.max_iterations = max_iterations, s.damping = damping;
  s.nullspace_gain = nullspace_gain, s.nullspace_tolerance = nullspace_tolerance;
  s.slide_iterations = slide_iterations, s.stall_window = stall_window;
  s.stall_ratio = stall_ratio;
  return out;
}

// A chain with its limits: the descent of dhkin.ik.numerical.NumericalIK.
class NumericalChain {
 public:
  NumericalChain(Input<double, nb::shape<-1, 4, 4>> before, Input<bool, nb::ndim<1>> revolute,
                 Input<double, nb::ndim<1>> direction, Input<double, nb::ndim<1>> offset,
                 Input<double, nb::shape<4, 4>> tail, Input<double, nb::ndim<1>> lower,
                 Input<double, nb::ndim<1>> upper) {
    joints_.chain = make_chain(before, revolute, direction, offset, tail);
    const std::size_t n = before.shape(0);
    joints_.revolute.resize(n);
    for (std::size_t j = 0; j < n; ++j) joints_.revolute[j] = revolute(j);
    joints_.lower = joint_vector(lower, dof(), "lower");
    joints_.upper = joint_vector(upper, dof(), "upper");
  }

  int dof() const { return joints_.dof(); }

  // q within the limits (numerical::project with 2 pi shifts) into out.
  void project(Input<double, nb::ndim<1>> q, Output<double, nb::ndim<1>> out) const {
    if (out.shape(0) != static_cast<std::size_t>(dof())) {
      throw std::invalid_argument("project: out has another joint count");
    }
    const numerical::JointVector projected =
        numerical::project(joints_, joint_vector(q, dof(), "q"), true);
    for (int j = 0; j < dof(); ++j) out(j) = projected[j];
  }

  // One descent from `start` (already within the limits or not: it is projected first); the
  // end point into q_out. Returns (position m, rotation rad or NaN, iterations, converged,
  // null-space motion rad).
  nb::tuple descend(const NumericalTask& task, const NumericalSettings& settings,
                    Input<double, nb::ndim<1>> start, Output<double, nb::ndim<1>> q_out) const {
    if (task.task.slides && task.task.preferred.size() != dof()) {
      throw std::invalid_argument("descend: the task's preference has another joint count");
    }
    const numerical::JointVector q0 = joint_vector(start, dof(), "start");
    if (q_out.shape(0) != static_cast<std::size_t>(dof())) {
      throw std::invalid_argument("descend: q_out has another joint count");
    }
    numerical::Outcome outcome;
    {
      nb::gil_scoped_release release;
      numerical::Descent descent(joints_, task.task, settings.settings);
      outcome = descent.run(q0);
    }
    for (int j = 0; j < dof(); ++j) q_out(j) = outcome.q[j];
    return nb::make_tuple(outcome.position, outcome.rotation, outcome.iterations,
                          outcome.converged, outcome.nullspace_motion);
  }

 private:
  numerical::Joints joints_;
};

}  // namespace

void bind_numerical(nb::module_& m) {
  m.attr("NUMERICAL_LAMBDA_FLOOR") = numerical::kLambdaFloor;
  nb::class_<NumericalTask>(m, "NumericalTask")
      .def(nb::new_(&make_task), "pose"_a, "rows"_a, "target_inverse"_a, "world_point"_a,
           "base_rotation_t"_a.none(), "tcp"_a.none(), "preferred"_a.none(),
           "weights"_a.none());
  nb::class_<NumericalSettings>(m, "NumericalSettings")
      .def(nb::new_(&make_settings), "method"_a, "tolerance"_a, "max_iterations"_a, "damping"_a,
           "nullspace_gain"_a, "nullspace_tolerance"_a, "slide_iterations"_a, "stall_window"_a,
           "stall_ratio"_a);
  nb::class_<NumericalChain>(m, "NumericalChain")
      .def(nb::init<Input<double, nb::shape<-1, 4, 4>>, Input<bool, nb::ndim<1>>,
                    Input<double, nb::ndim<1>>, Input<double, nb::ndim<1>>,
                    Input<double, nb::shape<4, 4>>, Input<double, nb::ndim<1>>,
                    Input<double, nb::ndim<1>>>(),
           "before"_a, "revolute"_a, "direction"_a, "offset"_a, "tail"_a, "lower"_a, "upper"_a)
      .def_prop_ro("dof", &NumericalChain::dof)
      .def("project", &NumericalChain::project, "q"_a, "out"_a)
      .def("descend", &NumericalChain::descend, "task"_a, "settings"_a, "start"_a, "q_out"_a);
}
