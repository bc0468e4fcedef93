"""Named offsets into the flat float vectors that carry constants to the kernels.

A kernel gets its constants as one float64 vector (numba compiles one version for every vector,
whatever it holds). :func:`layout` turns a list of (name, size) fields into a namedtuple of
offsets plus ``size``, so kernels read ``g[SHOULDER.origin + 1]`` instead of ``g[4]``; numba
freezes a global namedtuple into constants. :func:`pack` fills a vector from named values.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


def layout(name: str, fields: Sequence[tuple[str, int]]) -> Any:
    """A namedtuple type ``name`` instance: each field's offset, then ``size`` (total length)."""
    names = [field for field, _ in fields]
    if len(set(names)) != len(names) or "size" in names:
        raise ValueError(f"{name}: field names must be unique and not 'size', got {names}")
    offsets, at = [], 0
    for _, length in fields:
        offsets.append(at)
        at += length
    sizes = dict(fields)
    make_type: Callable[..., Any] = namedtuple  # field names known at run time only
    value = make_type(name, [*names, "size"])(*offsets, at)
    _SIZES[name] = sizes
    return value


#: Field sizes of every layout, by layout name (for :func:`pack`'s checks).
_SIZES: dict[str, dict[str, int]] = {}


def pack(spec: Any, values: Mapping[str, ArrayLike]) -> NDArray[np.float64]:
    """A float64 vector of ``spec.size`` with each named field set from ``values`` (every field
    must be given, with its size)."""
    sizes = _SIZES[type(spec).__name__]
    missing = set(sizes) - set(values)
    unknown = set(values) - set(sizes)
    if missing or unknown:
        raise ValueError(f"{type(spec).__name__}: missing fields {sorted(missing)}, "
                         f"unknown fields {sorted(unknown)}")
    out = np.zeros(spec.size)
    for field, length in sizes.items():
        data = np.asarray(values[field], dtype=float).ravel()
        if data.size != length:
            raise ValueError(f"{type(spec).__name__}.{field}: expected {length} values, "
                             f"got {data.size}")
        start = getattr(spec, field)
        out[start:start + length] = data
    return out
