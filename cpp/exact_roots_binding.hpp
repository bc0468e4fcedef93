// The general 6R solver of a table (dhkin._core.General6R) as the exact roots of a refined
// table's closed form (dhkin/exact_roots.hpp): the link between the two binding units.
#pragma once

#include <nanobind/nanobind.h>

#include <memory>

#include "dhkin/exact_roots.hpp"

namespace dhkin::bindings {

// The roots of `general` (a dhkin._core.General6R) on its exact chain to DH frame 6, held by the
// result (a copy of the solver: `general` may go). TypeError for any other object.
std::shared_ptr<const ExactRoots> exact_roots_of(nanobind::handle general);

}  // namespace dhkin::bindings
