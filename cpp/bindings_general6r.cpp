// dhkin._core.General6R: the general 6R solver's per-pose work (cpp/dhkin/general6r/*.hpp).
//
// Built once per table (and arrangement) from named values (dhkin.ik.general6r.General6RSolver
// .core_fields); the per-pose calls take C-contiguous float64 arrays and release the GIL, so that
// Python threads can share a batch.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>

#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "array_io.hpp"
#include "exact_roots_binding.hpp"
#include "dhkin/general6r/reference.hpp"
#include "dhkin/general6r/solver.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using dhkin::Frame;
using dhkin::Joints;
using dhkin::kDof;
namespace g6 = dhkin::general6r;

using dhkin::raw_frame;
using dhkin::bindings::chain_of;
using dhkin::bindings::Input;
using Pose = Input<double, nb::shape<4, 4>>;

std::vector<double> field(const nb::dict& fields, const char* name, long size = -1) {
  if (!fields.contains(name)) throw std::invalid_argument(std::string("missing field ") + name);
  const auto array = nb::cast<Input<double>>(fields[name]);
  if (size >= 0 && array.size() != static_cast<std::size_t>(size)) {
    throw std::invalid_argument(std::string("field ") + name + ": expected " +
                                std::to_string(size) + " values, got " +
                                std::to_string(array.size()));
  }
  return std::vector<double>(array.data(), array.data() + array.size());
}

Joints joints_of(const std::vector<double>& v, std::size_t first = 0) {
  Joints q;
  for (int j = 0; j < kDof; ++j) q[j] = v[first + j];
  return q;
}

// One arrangement's elimination from its named values.
g6::Elimination elimination_from(const nb::dict& f) {
  g6::Elimination el;
  const auto P = field(f, "P", 3 * g6::kQuantities * g6::kProducts);
  for (int c = 0; c < 3; ++c) {
    for (int q = 0; q < g6::kQuantities; ++q) {
      for (int p = 0; p < g6::kProducts; ++p) {
        el.P[c](q, p) = P[(c * g6::kQuantities + q) * g6::kProducts + p];
      }
    }
  }
  const auto before = field(f, "before", 16 * g6::kProducts);
  const auto after = field(f, "after", 16 * g6::kProducts);
  for (int s9 = 0; s9 < g6::kProducts; ++s9) {
    el.before[s9] = raw_frame(before.data() + 16 * s9);
    el.after[s9] = raw_frame(after.data() + 16 * s9);
  }
  const auto right_inverse = field(f, "right_inverse", 81), half2 = field(f, "half2", 81);
  for (int r = 0; r < 9; ++r) {
    for (int c = 0; c < 9; ++c) {
      el.right_inverse(r, c) = right_inverse[9 * r + c];
      el.half2(r, c) = half2[9 * r + c];
    }
  }
  const auto mix = field(f, "mix", 6 * g6::kQuantities);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < g6::kQuantities; ++c) el.mix(r, c) = mix[g6::kQuantities * r + c];
  }
  const auto rows = field(f, "rows", 3 * kDof);
  for (int j = 0; j < kDof; ++j) el.rows[j] = {rows[3 * j], rows[3 * j + 1], rows[3 * j + 2]};
  el.phi = joints_of(field(f, "phi", kDof));
  el.D0_inverse = raw_frame(field(f, "D0_inverse", 16).data());
  el.E_inverse = raw_frame(field(f, "E_inverse", 16).data());
  el.shift = field(f, "shift", 1)[0];
  el.k = static_cast<int>(field(f, "k", 1)[0]);
  if (el.k < 0 || el.k > 2) throw std::invalid_argument("field k: expected 0, 1 or 2");
  el.reversed = field(f, "reversed", 1)[0] != 0.0;
  el.scale = field(f, "scale", 1)[0];
  el.band = field(f, "band", 1)[0];
  const auto spurious = field(f, "spurious");
  if (spurious.size() == static_cast<std::size_t>(g6::kEigenvalues * g6::kSpurious)) {
    for (int r = 0; r < g6::kEigenvalues; ++r) {
      for (int c = 0; c < g6::kSpurious; ++c) el.spurious(r, c) = spurious[g6::kSpurious * r + c];
    }
    el.has_spurious = true;
  } else if (!spurious.empty()) {
    throw std::invalid_argument("field spurious: expected 24 x 8 values or none");
  }
  el.direction = joints_of(field(f, "direction", kDof));
  el.offset = joints_of(field(f, "offset", kDof));
  return el;
}

// The solver from its named values; `others`: the other regular arrangements' eliminations
// (each a dict of elimination_from's values), solved where a root is singular.
g6::Solver solver_from(const nb::dict& f, const nb::list& others) {
  g6::Solver s;
  s.elimination = elimination_from(f);
  for (const nb::handle other : others) {
    s.others.push_back(elimination_from(nb::cast<nb::dict>(other)));
  }
  const auto twist = field(f, "twist", 6);
  for (int i = 0; i < 6; ++i) s.moves.twist[i] = twist[i];
  const auto fallback = field(f, "fallback");
  if (fallback.size() % kDof) throw std::invalid_argument("field fallback: expected (n, 6)");
  for (std::size_t i = 0; i < fallback.size(); i += kDof) {
    s.moves.fallback.push_back(joints_of(fallback, i));
  }
  const auto chain_before = field(f, "chain_before", 16 * kDof);
  const auto chain_direction = field(f, "chain_direction", kDof);
  const auto chain_offset = field(f, "chain_offset", kDof);
  s.dh_chain = chain_of(kDof, chain_before.data(), nullptr, chain_direction.data(),
                        chain_offset.data(), field(f, "chain_tail", 16).data());
  s.tool = raw_frame(field(f, "tool", 16).data());
  s.base_inverse = raw_frame(field(f, "base_inverse", 16).data());
  const auto lower = field(f, "lower", kDof), upper = field(f, "upper", kDof);
  for (int j = 0; j < kDof; ++j) s.limits[j] = {lower[j], upper[j]};
  s.lever = field(f, "lever", 1)[0];
  s.links = field(f, "links", 1)[0];
  return s;
}

// A numpy array owning `values` (moved), of the given shape.
template <class T>
nb::ndarray<nb::numpy, T> owned(std::vector<T>&& values, std::initializer_list<std::size_t> shape) {
  auto* data = new std::vector<T>(std::move(values));
  nb::capsule owner(data, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(data->data(), shape, owner);
}

// Rows as arrays: q (k, 6), errors (k, 2), singular (k,).
nb::tuple rows_arrays(const std::vector<g6::Solution>& rows) {
  std::vector<double> q, errors;
  std::vector<std::uint8_t> singular;
  q.reserve(kDof * rows.size());
  errors.reserve(2 * rows.size());
  singular.reserve(rows.size());
  for (const g6::Solution& row : rows) {
    q.insert(q.end(), row.q.begin(), row.q.end());
    errors.push_back(row.error.position);
    errors.push_back(row.error.rotation);
    singular.push_back(row.singular ? 1 : 0);
  }
  const std::size_t k = rows.size();
  return nb::make_tuple(owned(std::move(q), {k, kDof}), owned(std::move(errors), {k, 2}),
                        owned(std::move(singular), {k}));
}

// A batch's answers as arrays: (q (R, 6), errors (R, 2), singular (R,)), counts (N,),
// projection (N,), dropped (N,), first rejected pose or -1, its status.
nb::tuple batch_arrays(g6::BatchAnswers&& out) {
  const std::size_t answered = out.counts.size();
  return nb::make_tuple(rows_arrays(out.rows), owned(std::move(out.counts), {answered}),
                        owned(std::move(out.projection), {answered}),
                        owned(std::move(out.dropped), {answered}), out.rejected, out.status);
}

class General6R {
 public:
  General6R(const nb::dict& fields, const nb::list& others)
      : solver_(solver_from(fields, others)) {}

  // The tip at tool0, or at the TCP `tcp` (None: tool0).
  g6::Tip tip(const nb::object& tcp) const {
    if (tcp.is_none()) return solver_.tip();
    const Frame frame = raw_frame(nb::cast<Pose>(tcp).data());
    return solver_.tip(&frame);
  }

  // The starts of one elimination of T_dh: (q (m, 6), origin (m,), lead condition, degenerate).
  nb::tuple candidates(Pose T_dh) const {
    std::vector<g6::Start> starts;
    g6::EliminationInfo info;
    {
      nb::gil_scoped_release release;
      info = g6::candidates(solver_.elimination, raw_frame(T_dh.data()), starts);
    }
    std::vector<double> q;
    std::vector<std::int64_t> origin;
    for (const g6::Start& start : starts) {
      q.insert(q.end(), start.q.begin(), start.q.end());
      origin.push_back(start.origin);
    }
    const std::size_t m = starts.size();
    return nb::make_tuple(owned(std::move(q), {m, kDof}), owned(std::move(origin), {m}),
                          info.lead_condition, info.degenerate);
  }

  // The verified roots of T_dh (DH frame 0 -> DH frame 6) at `tolerance` on the chain to DH
  // frame 6: (roots (k, 6), errors (k, 2), starts that failed, sigmas (k,)).
  nb::tuple roots(Pose T_dh, double tolerance) const {
    std::vector<g6::Root> roots;
    int failed = 0;
    {
      nb::gil_scoped_release release;
      const Frame target = raw_frame(T_dh.data());
      failed = g6::settled_roots(solver_, solver_.dh_tip(), target, target, tolerance, roots);
    }
    std::vector<double> q, errors, sigmas;
    for (const g6::Root& root : roots) {
      q.insert(q.end(), root.q.begin(), root.q.end());
      errors.push_back(root.error.position);
      errors.push_back(root.error.rotation);
      sigmas.push_back(root.sigma);
    }
    const std::size_t k = roots.size();
    return nb::make_tuple(owned(std::move(q), {k, kDof}), owned(std::move(errors), {k, 2}),
                          failed, owned(std::move(sigmas), {k}));
  }

  // The smallest singular value of the Jacobian at tool0 at q (linear rows over the lever).
  double smallest_singular(Input<double, nb::shape<kDof>> q) const {
    const g6::Tip at = solver_.tip();
    Joints values;
    for (int j = 0; j < kDof; ++j) values[j] = q(j);
    return g6::smallest_singular(at.chain, values, at.lever, INFINITY);
  }

  // One pose: (outcome, status, projection, distance, failed, verified, q, errors, singular).
  nb::tuple solve(Pose T, Input<double, nb::shape<kDof>> seed, double tolerance, bool copies,
                  const nb::object& tcp) const {
    const g6::Tip at = tip(tcp);
    Joints q_seed;
    for (int j = 0; j < kDof; ++j) q_seed[j] = seed(j);
    g6::Answer answer;
    {
      nb::gil_scoped_release release;
      answer = g6::solve(solver_, at, T.data(), q_seed, tolerance, copies);
    }
    return nb::make_tuple(static_cast<int>(answer.outcome), answer.status, answer.projection,
                          answer.distance, answer.failed, answer.verified,
                          rows_arrays(answer.rows));
  }

  // N poses (N, 4, 4) for each of S seed sets (S, 1 or N, 6), each pose's roots found once: a
  // list of S tuples (batch_arrays), the answer of each seed set.
  nb::list solve_batch_seeds(Input<double, nb::shape<-1, 4, 4>> T,
                             Input<double, nb::shape<-1, -1, kDof>> seeds, double tolerance,
                             bool copies, const nb::object& tcp) const {
    const std::size_t n = T.shape(0), rows = seeds.shape(1);
    if (rows != 1 && rows != n) {
      throw std::invalid_argument("seeds: expected 1 or N rows per set");
    }
    const std::size_t stride = rows == 1 ? 0 : kDof;
    std::vector<const double*> sets;
    for (std::size_t s = 0; s < seeds.shape(0); ++s) {
      sets.push_back(seeds.data() + s * rows * kDof);
    }
    const g6::Tip at = tip(tcp);
    std::vector<g6::BatchAnswers> out;
    {
      nb::gil_scoped_release release;
      out = g6::solve_batch_seeds(solver_, at, T.data(), n, sets, stride, tolerance, copies);
    }
    nb::list answers;
    for (g6::BatchAnswers& answer : out) answers.append(batch_arrays(std::move(answer)));
    return answers;
  }

  const g6::Solver& solver() const { return solver_; }

 private:
  g6::Solver solver_;
};

// The roots of one table's exact chain to DH frame 6 (dhkin/exact_roots.hpp), by its solver.
class GeneralRoots final : public dhkin::ExactRoots {
 public:
  explicit GeneralRoots(const g6::Solver& solver) : solver_(solver), tip_(solver_.dh_tip()) {}

  void find(const Frame& T_dh, double verification,
            std::vector<dhkin::ExactRoot>& out) const override {
    out.clear();
    // beyond the links (with the tolerance's margin) no root: nothing to eliminate
    if (!(g6::reach_distance(T_dh) <= solver_.reach(verification, tip_))) return;
    std::vector<g6::Root> roots;
    g6::settled_roots(solver_, tip_, T_dh, T_dh, verification, roots);
    out.reserve(roots.size());
    for (const g6::Root& root : roots) {
      dhkin::ExactRoot exact;
      for (int j = 0; j < kDof; ++j) exact.q[j] = dhkin::wrap(root.q[j]);
      exact.error = root.error;
      exact.sigma = root.sigma;
      out.push_back(exact);
    }
  }

  double singular_band(double verification) const override {
    return g6::singular_band(verification);
  }

 private:
  g6::Solver solver_;
  g6::Tip tip_;
};

}  // namespace

std::shared_ptr<const dhkin::ExactRoots> dhkin::bindings::exact_roots_of(nb::handle general) {
  const General6R* solver = nullptr;
  if (!nb::try_cast<const General6R*>(general, solver) || solver == nullptr) {
    throw nb::type_error("exact roots: expected a dhkin._core.General6R");
  }
  return std::make_shared<const GeneralRoots>(solver->solver());
}

void bind_general6r(nb::module_& m) {
  nb::class_<General6R>(m, "General6R")
      .def(nb::init<const nb::dict&, const nb::list&>(), "fields"_a, "others"_a)
      .def("candidates", &General6R::candidates, "T_dh"_a)
      .def("roots", &General6R::roots, "T_dh"_a, "tolerance"_a)
      .def("smallest_singular", &General6R::smallest_singular, "q"_a)
      .def("solve", &General6R::solve, "T"_a, "seed"_a, "tolerance"_a, "copies"_a,
           "tcp"_a = nb::none())
      .def("solve_batch_seeds", &General6R::solve_batch_seeds, "T"_a, "seeds"_a, "tolerance"_a,
           "copies"_a, "tcp"_a = nb::none());
  m.def(
      "general6r_multistart",
      [](Input<double, nb::shape<kDof, 4, 4>> before, Input<double, nb::shape<kDof>> direction,
         Input<double, nb::shape<kDof>> offset, Pose tail, Pose target,
         Input<double, nb::shape<-1, kDof>> starts, double tolerance, std::size_t patience,
         std::size_t most) {
        const dhkin::Chain chain = chain_of(kDof, before.data(), nullptr, direction.data(),
                                             offset.data(), tail.data());
        std::vector<Joints> start_rows(starts.shape(0));
        for (std::size_t i = 0; i < start_rows.size(); ++i) {
          for (int j = 0; j < kDof; ++j) start_rows[i][j] = starts(i, j);
        }
        std::vector<Joints> roots;
        {
          nb::gil_scoped_release release;
          roots = g6::multistart(chain, raw_frame(target.data()), start_rows, tolerance, patience,
                                 most);
        }
        std::vector<double> q;
        for (const Joints& root : roots) q.insert(q.end(), root.begin(), root.end());
        return owned(std::move(q), {roots.size(), kDof});
      },
      "before"_a, "direction"_a, "offset"_a, "tail"_a, "target"_a, "starts"_a, "tolerance"_a,
      "patience"_a, "most"_a,
      "The distinct roots (k, 6) that Newton reaches from the starts (general6r/reference.hpp).");
}
