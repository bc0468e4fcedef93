"""ik_batch and the compiled pipeline: the same answers as ik, chunking, copies, memory.

Speed is measured by scripts/bench_ik.py (docs/benchmarks.md), never asserted here. What is
checked: ``ik_batch`` returns pose by pose exactly what ``ik`` returns (one implementation: the
batch runs the single-pose function per pose), whatever the chunk size, streamed or not; by
default each branch gives one solution, its in-limit 2pi copy nearest the seed (nearest 0
without one), and ``copies=True`` every in-limit copy; ``branches`` gives the copies' source;
the elementary functions of the kernels are accurate to a few ulp; the kernels are safe to call
from several threads; a batch of 10^6 poses runs within a bounded amount of memory.
"""

from __future__ import annotations

import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import dhkin
from dhkin import _core
from dhkin.errors import InputError
from dhkin.ik.result import flag_names
from dhkin.ik.workers import POSES_PER_WORKER
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error

DATA = Path(__file__).resolve().parent / "data"
TWO_PI = 2.0 * np.pi
#: Every robot with a closed-form family: built-in and test tables, both DH conventions.
ROBOTS = ["abb_irb1200_7_70", "anthropomorphic_arm", "stanford_arm", "ur3", "ur5", "ur10",
          "aubo_i10", str(DATA / "puma560_modified.yaml"), str(DATA / "puma560_standard.yaml"),
          str(DATA / "abb_irb1200_7_70_modified.yaml"), str(DATA / "custom_arm_modified.yaml"),
          str(DATA / "ur3_seed004.yaml")]
SPECIAL_ANGLES = np.array([0.0, np.pi / 2, -np.pi / 2, np.pi, -np.pi])


def pose_set(robot: dhkin.Robot, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n poses (N, 4, 4): random joint vectors, a quarter at q5 = 0, some at special angles
    and a few out of reach; and random seeds (N, dof)."""
    rng = np.random.default_rng(seed)
    q = robot.table.random_q(n, rng)
    q[: n // 4, 4] = 0.0
    special = slice(n // 4, n // 2)
    for j, joint in enumerate(robot.table.joints):
        inside = (joint.lower <= SPECIAL_ANGLES) & (joint.upper >= SPECIAL_ANGLES)
        allowed = SPECIAL_ANGLES[inside]
        if joint.is_revolute and allowed.size:
            q[special, j] = rng.choice(allowed, size=n // 2 - n // 4)
    T = robot.fk(q)
    T[-5:, :3, 3] += 100.0  # unreachable
    return np.ascontiguousarray(T), robot.table.random_q(n, rng)


@pytest.fixture(scope="module", params=ROBOTS, ids=lambda name: Path(name).stem)
def robot(request, load_robot) -> dhkin.Robot:
    return load_robot(request.param)


# --------------------------------------------------------------------------------------------
# ik_batch == ik


@pytest.mark.parametrize("copies", [True, False])
def test_ik_batch_equals_ik_pose_by_pose(robot, copies):
    """Same solutions, same order, same flags and branches; every one exact."""
    T, seeds = pose_set(robot, 120, seed=7)
    batch = robot.ik_batch_detailed(T, seeds, copies=copies)
    Q, valid = robot.ik_batch(T, seeds, copies=copies)
    np.testing.assert_array_equal(Q, batch.q)
    np.testing.assert_array_equal(valid, batch.valid)
    # each pose's solutions first, then its empty slots (zeros, branch -1)
    assert not (np.diff(batch.valid.astype(int), axis=1) > 0).any()
    empty = ~batch.valid
    assert (batch.q[empty] == 0).all() and (batch.residuals[empty] == 0).all()
    assert (batch.branch[empty] == -1).all() and (batch.flags[empty] == 0).all()
    for i in range(len(T)):
        solutions = robot.ik(T[i], seeds[i], copies=copies)
        keep = batch.valid[i]
        np.testing.assert_array_equal(solutions.q, batch.q[i][keep])
        assert solutions.flags == tuple(flag_names(f) for f in batch.flags[i][keep])
        labels = [dict(batch.branch_labels[b]) for b in batch.branch[i][keep]]
        assert [dict(c.labels) for c in solutions.configurations] == labels
        turns = np.where([j.is_revolute for j in robot.table.joints],
                         np.round(solutions.q / TWO_PI), 0).astype(int)
        assert [c.turns for c in solutions.configurations] == [tuple(t) for t in turns]
        if len(solutions):
            assert solutions.residuals.max() <= 1e-9
            position, rotation = pose_error(robot.fk(solutions.q),
                                            np.broadcast_to(T[i], (len(solutions), 4, 4)))
            assert position.max() <= 1e-9 and rotation.max() <= 1e-9
        else:
            assert solutions.reason
    assert not batch.valid[-5:].any()  # the unreachable ones


def _every_slot_written(robot: dhkin.Robot, T: np.ndarray, seeds: np.ndarray) -> None:
    reference = robot.ik_batch_detailed(T, seeds)
    solver = robot.ik_solver
    N, B, n = len(T), solver.n_branches, robot.dof
    out = (np.full((N, B, n), np.nan), np.ones((N, B), np.bool_), np.full((N, B), 7, np.int16),
           np.full((N, B), 255, np.uint8), np.full((N, B, 2), np.nan))
    projection, dropped = np.full(N, np.nan), np.full(N, -7, np.int64)
    rejected, _, width = solver.core.nearest(T, seeds, DEFAULT_TOLERANCE, solver.frames, *out,
                                             projection, dropped)
    assert rejected == -1 and width == reference.q.shape[1]
    for got, want in zip(out, (reference.q, reference.valid, reference.branch, reference.flags,
                               reference.residuals), strict=True):
        np.testing.assert_array_equal(got[:, :width], want)
        empty = -1 if got.dtype == np.int16 else 0  # branch -1, every other value zero
        np.testing.assert_array_equal(got[:, width:], np.full_like(got[:, width:], empty))
    np.testing.assert_array_equal(projection, reference.projection)
    np.testing.assert_array_equal(dropped, reference.dropped)


def test_the_core_writes_every_slot_of_a_batch_without_copies(robot):
    """ik_batch without copies hands the core uninitialised arrays: every slot of every pose,
    the empty ones too, comes back as when the arrays start out filled with other values."""
    _every_slot_written(robot, *pose_set(robot, 120, seed=8))


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_every_slot_of_a_batch_larger_than_the_caches(load_robot, name):
    """The same for a result beyond the second-level cache (10 MB), written by streaming
    stores (cpp/dhkin/batch.hpp): random poses, a few out of reach."""
    robot = load_robot(name)
    rng = np.random.default_rng(9)
    T = robot.fk(robot.table.random_q(20_000, rng))
    T[::1000, :3, 3] += 100.0  # unreachable: every slot empty
    _every_slot_written(robot, np.ascontiguousarray(T), robot.table.random_q(20_000, rng))


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_rounded_poses_give_ik_answers_in_a_batch(load_robot, name):
    """A batch projects the rotation blocks of eight poses at once, each pose stopping at its own
    Newton step; a single call projects its pose alone. Poses rounded to six decimals and to
    float32 (several steps each, mixed with exact ones that stop after one) give ik's solutions,
    residuals and projection pose by pose, bit for bit."""
    robot = load_robot(name)
    T, seeds = pose_set(robot, 96, seed=11)
    rounded = np.round(T, 6)
    short = T.astype(np.float32).astype(np.float64)
    rounded[:, 3] = short[:, 3] = [0.0, 0.0, 0.0, 1.0]
    targets = np.ascontiguousarray(np.stack([T, rounded, short], axis=1).reshape(-1, 4, 4))
    seeds = np.repeat(seeds, 3, axis=0)
    batch = robot.ik_batch_detailed(targets, seeds)
    for moved in (batch.projection[1::3], batch.projection[2::3]):  # special angles round exactly
        assert np.count_nonzero(moved > 1e-8) >= len(T) // 2
    for i in range(len(targets)):
        solutions = robot.ik(targets[i], seeds[i])
        keep = batch.valid[i]
        np.testing.assert_array_equal(solutions.q, batch.q[i][keep])
        np.testing.assert_array_equal(solutions.residuals, batch.residuals[i][keep])
        assert solutions.projection == batch.projection[i]


def test_chunk_sizes_and_streaming_give_identical_results(robot):
    T, seeds = pose_set(robot, 90, seed=8)
    whole = robot.ik_batch_detailed(T, seeds)
    for chunk_size in (1, 7, 64):
        chunked = robot.ik_batch_detailed(T, seeds, chunk_size=chunk_size)
        for field in ("q", "valid", "flags", "branch"):
            np.testing.assert_array_equal(getattr(chunked, field), getattr(whole, field))
    seen = 0
    for start, part in robot.ik_batch_chunks(T, seeds, chunk_size=13):
        for k in range(part.q.shape[0]):
            i = start + k
            np.testing.assert_array_equal(part.q[k][part.valid[k]], whole.q[i][whole.valid[i]])
            np.testing.assert_array_equal(part.branch[k][part.valid[k]],
                                          whole.branch[i][whole.valid[i]])
        seen += part.q.shape[0]
    assert seen == len(T)


def test_default_is_one_solution_per_branch_its_copy_nearest_the_seed(robot):
    """copies=False (the default): the same branches as copies=True, each the in-limit copy
    nearest the seed on every joint (nearest 0 without a seed); the branch's principal value
    (robot.ik_solver.branches) is a 2pi copy of it."""
    T, seeds = pose_set(robot, 90, seed=9)
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    for seed in (seeds, None):
        every = robot.ik_batch_detailed(T, seed, copies=True)
        one = robot.ik_batch_detailed(T, seed)
        branches = robot.ik_solver.branches(T, seed)
        aim = np.zeros_like(seeds) if seed is None else seeds
        assert one.q.shape[1] <= len(robot.ik_solver.branch_labels)
        for i in range(len(T)):
            chosen = one.branch[i][one.valid[i]]
            assert sorted(chosen) == sorted(set(every.branch[i][every.valid[i]]))
            for b, q in zip(chosen, one.q[i][one.valid[i]], strict=True):
                rows = every.q[i][every.valid[i] & (every.branch[i] == b)]
                assert np.any(np.all(np.abs(rows - q) <= 1e-12, axis=1))
                distance = np.abs(q - aim[i])
                assert np.all(distance <= np.abs(rows - aim[i]).min(axis=0) + 1e-12)
                principal = branches.q[i, b]
                assert branches.valid[i, b]
                shift = np.where(revolute, np.mod(q - principal + np.pi, TWO_PI) - np.pi,
                                 q - principal)
                assert np.abs(shift).max() <= 1e-9


def test_every_copy_inside_the_limits_and_no_other(robot):
    """copies=True: per branch, exactly the 2pi copies of its principal value that lie inside
    the joint limits (counted independently here), each exact."""
    T, seeds = pose_set(robot, 60, seed=10)
    every = robot.ik_batch_detailed(T, seeds, copies=True)
    branches = robot.ik_solver.branches(T, seeds)
    lower, upper = robot.lower, robot.upper
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    for i in range(len(T)):
        for b in np.flatnonzero(branches.valid[i]):
            principal = branches.q[i, b]
            counts = []
            for j in range(robot.dof):
                if revolute[j]:
                    shifts = principal[j] + TWO_PI * np.arange(-4, 5)
                    counts.append(int(((shifts >= lower[j] - 1e-9)
                                       & (shifts <= upper[j] + 1e-9)).sum()))
                else:
                    counts.append(int(lower[j] <= principal[j] <= upper[j]))
            rows = every.q[i][every.valid[i] & (every.branch[i] == b)]
            assert len(rows) == int(np.prod(counts))
            assert len({tuple(np.round(r, 9)) for r in rows}) == len(rows)
            assert np.all((rows >= lower) & (rows <= upper))
        if every.valid[i].any():
            values = every.q[i][every.valid[i]]
            position, rotation = pose_error(robot.reference().fk(values),
                                            np.broadcast_to(T[i], (len(values), 4, 4)))
            assert position.max() <= 1e-9 and rotation.max() <= 1e-9


# --------------------------------------------------------------------------------------------
# Elementary functions of the compiled core (cpp/dhkin/angles.hpp)


def _sincos_array(x: np.ndarray, out: np.ndarray) -> None:
    out[:] = _core.sincos(x)


def _atan2_array(y: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    out[:] = _core.atan2(y, x)


def test_sincos_within_a_few_ulp_and_the_c_library_beyond_its_range():
    rng = np.random.default_rng(11)
    x = np.concatenate([rng.uniform(-20, 20, 200_000), np.arange(-16, 17) * np.pi / 4,
                        [0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e6, -3e7, 1e300]])
    out = np.empty((len(x), 2))
    _sincos_array(x, out)
    np.testing.assert_allclose(out[:, 0], np.sin(x), rtol=0, atol=4.5e-16)
    np.testing.assert_allclose(out[:, 1], np.cos(x), rtol=0, atol=4.5e-16)
    special = np.array([np.nan, np.inf, -np.inf])
    out = np.empty((3, 2))
    _sincos_array(special, out)
    assert np.isnan(out).all()


def test_atan2_within_a_few_ulp_and_exact_at_zeros_and_infinities():
    rng = np.random.default_rng(12)
    magnitude = 10.0 ** rng.uniform(-300, 300, (2, 200_000))
    y = rng.choice([-1.0, 1.0], 200_000) * magnitude[0] * rng.uniform(0, 1, 200_000)
    x = rng.choice([-1.0, 1.0], 200_000) * magnitude[1] * rng.uniform(0, 1, 200_000)
    y = np.concatenate([y, rng.normal(size=100_000), [1.0, -1.0, 1.0, -1.0, 3.0, 3.0]])
    x = np.concatenate([x, rng.normal(size=100_000), [1.0, 1.0, -1.0, -1.0, 3.0, -3.0]])
    out = np.empty(len(x))
    _atan2_array(y, x, out)
    reference = np.arctan2(y, x)
    assert np.all(np.abs(out - reference) <= 2.5 * np.spacing(np.abs(reference)) + 1e-300)
    values = np.array([0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan])
    ys, xs = (a.ravel() for a in np.meshgrid(values, values))
    out = np.empty(len(xs))
    _atan2_array(ys, xs, out)
    np.testing.assert_array_equal(out, np.arctan2(ys, xs))
    assert np.signbit(out).tolist() == np.signbit(np.arctan2(ys, xs)).tolist()


def test_atan2_is_the_quotient_up_to_the_linear_bound():
    """chain.hpp's rotation_angle takes s / c for atan2(s, c) where s <= 2^-27 c (c > 0, finite):
    the same bits, on quotients spread over every binade below the bound, at the bound, and for
    c over the whole range; just above the bound the polynomial's term does change some."""
    bound = 2.0 ** -27
    rng = np.random.default_rng(14)
    n = 200_000
    c = np.concatenate([rng.uniform(0.5, 1.0, n), 1.0 - rng.uniform(0, 1e-9, n),
                        10.0 ** rng.uniform(-300, 300, n)])
    ratio = np.concatenate([bound * 2.0 ** -rng.uniform(0, 60, 2 * n), bound * rng.uniform(
        0.999, 1.0, n)])
    s = ratio * c
    s = np.concatenate([s, [0.0, 5e-324, bound * 0.75], bound * 2.0 ** -np.arange(0, 1000.0)])
    c = np.concatenate([c, [1.0, 1.0, 0.75], np.ones(1000)])
    below = s <= bound * c
    assert below.mean() > 0.99
    s, c = s[below], c[below]
    out = np.empty(len(s))
    _atan2_array(s, c, out)
    assert np.array_equal(out.view(np.int64), (s / c).view(np.int64))
    above = bound * rng.uniform(2.0, 8.0, n)
    out = np.empty(n)
    _atan2_array(above, np.ones(n), out)
    assert not np.array_equal(out, above)


def test_wrap_to_minus_pi_exclusive_pi_inclusive():
    """wrap(x) is x less whole turns, in (-pi, pi]: within a few ulp of the exact remainder
    (numpy's, with -pi taken to pi) over +-20 rad, the turns' edges and beyond 2^19 rad."""
    rng = np.random.default_rng(13)
    x = np.concatenate([rng.uniform(-20, 20, 200_000), np.arange(-9, 10) * np.pi,
                        np.nextafter(np.arange(-9, 10) * np.pi, np.inf),
                        np.nextafter(np.arange(-9, 10) * np.pi, -np.inf), [1e6, -3e7, 1e300]])
    out = _core.wrap(x)
    reference = np.remainder(x + np.pi, 2 * np.pi) - np.pi
    reference[reference == -np.pi] = np.pi
    assert np.all((out > -np.pi) & (out <= np.pi))
    difference = np.abs(np.remainder(out - reference + np.pi, 2 * np.pi) - np.pi)
    assert np.all(difference <= 4 * np.spacing(np.maximum(np.abs(x), np.pi)))


# --------------------------------------------------------------------------------------------
# Threads, input errors


def test_the_core_says_which_vector_width_it_was_built_for():
    """VECTOR_WIDTH (doubles a vector register; benchmarks print it with the machine) is one of
    the widths cpp/dhkin/simd.hpp builds for, and a build for AVX-512 runs only where the CPU has
    it (the import would have failed with an illegal instruction otherwise; Linux's cpuinfo)."""
    assert _core.VECTOR_WIDTH in (2, 4, 8)
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            flags = next((line for line in info if line.startswith("flags")), "").split()
    except OSError:
        flags = []
    if flags and _core.VECTOR_WIDTH == 8:
        assert "avx512f" in flags
    if flags and _core.VECTOR_WIDTH == 4:
        assert "avx" in flags


def test_threads_get_the_same_answers(load_robot):
    """The kernels release the GIL and robot.ik keeps its buffers per thread."""
    robot = load_robot("ur5")
    T, seeds = pose_set(robot, 200, seed=13)
    expected = [robot.ik(T[i], seeds[i]).q for i in range(len(T))]
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda i: robot.ik(T[i], seeds[i]).q, range(len(T))))
        batches = list(pool.map(lambda part: robot.ik_batch(T[part], seeds[part]),
                                [slice(0, 100), slice(100, 200)]))
    for a, b in zip(expected, got, strict=True):
        np.testing.assert_array_equal(a, b)
    for part, (Q, valid) in zip((slice(0, 100), slice(100, 200)), batches, strict=True):
        for k, i in enumerate(range(part.start, part.stop)):
            np.testing.assert_array_equal(Q[k][valid[k]], expected[i])


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_worker_threads_share_a_batch_without_changing_it(load_robot, name):
    """A batch large enough to be split (POSES_PER_WORKER per thread) gives, field by field, the
    same result on 1, 2 and 3 threads; a bad pose in the second slice is named by its index."""
    robot = load_robot(name)
    T, seeds = pose_set(robot, 3 * POSES_PER_WORKER + 17, seed=21)
    one = robot.ik_batch_detailed(T, seeds, workers=1)
    for workers in (2, 3, None):
        shared = robot.ik_batch_detailed(T, seeds, workers=workers)
        for field in ("q", "valid", "flags", "branch", "residuals", "projection", "dropped"):
            np.testing.assert_array_equal(getattr(shared, field), getattr(one, field))
    bad = T.copy()
    bad[2 * POSES_PER_WORKER + 3, :3, :3] *= 2.0
    with pytest.raises(InputError, match=rf"T\[{2 * POSES_PER_WORKER + 3}\]: rotation"):
        robot.ik_batch(bad, workers=3)
    for wrong in (0, -1, 1.5, True, "2"):
        with pytest.raises(InputError, match=r"workers: expected a positive integer or None"):
            robot.ik_batch(T[:3], workers=wrong)


def test_ik_takes_any_array_layout_through_the_compiled_entry_point(load_robot):
    """robot.ik calls the compiled core, which reads C-contiguous float64 arrays: lists, Fortran
    order, strided views, read-only and integer arrays must be converted first and give the
    answers of the plain call."""
    robot = load_robot("ur5")
    q = robot.table.random_q(50, np.random.default_rng(19))
    T = robot.fk(q)
    answered = np.zeros(len(T), np.bool_)  # the fast path (the core's direct path) is in use
    robot.ik_solver.core.direct_answers(T, q, 1e-9, robot.ik_solver.frames, answered)
    assert answered.all()
    for i in range(len(T)):
        expected = robot.ik(np.ascontiguousarray(T[i]), q[i])
        wide = np.zeros((8, 8))
        wide[::2, ::2] = T[i]
        frozen = np.array(T[i])
        frozen.flags.writeable = False
        seeds = (q[i].tolist(), np.repeat(q[i], 2)[::2], np.asfortranarray(q[i]))
        targets = (T[i].tolist(), np.asfortranarray(T[i]), wide[::2, ::2], frozen)
        for target, seed in zip(targets, (*seeds, q[i]), strict=True):
            got = robot.ik(target, seed)
            np.testing.assert_array_equal(got.q, expected.q)
            np.testing.assert_array_equal(got.residuals, expected.residuals)
            assert got.configurations == expected.configurations
    integer_pose = np.eye(4, dtype=np.int64)
    integer_pose[:3, 3] = (1, 0, 0)  # out of reach: an empty answer, not a type error
    assert len(robot.ik(integer_pose)) == 0


def test_bad_inputs_name_the_pose(load_robot):
    robot = load_robot("abb_irb1200_7_70")
    T = robot.fk(robot.table.random_q(40, np.random.default_rng(14)))
    bad = T.copy()
    bad[33, :3, :3] *= 2.0
    with pytest.raises(InputError, match=r"T\[33\]: rotation block is not a rotation"):
        robot.ik_batch(bad)
    with pytest.raises(InputError, match=r"T\[33\]: rotation block is not a rotation"):
        list(robot.ik_batch_chunks(bad, chunk_size=10))
    with pytest.raises(InputError, match=r"T\[33\]: rotation block is not a rotation"):
        robot.ik_solver.branches(bad)
    bad[5, 0, 0] = np.nan
    with pytest.raises(InputError, match="finite"):
        robot.ik_batch(bad, chunk_size=3)
    with pytest.raises(InputError, match="finite"):
        robot.ik(bad[5])
    with pytest.raises(InputError, match=r"q_seed: expected finite values, got .*inf"):
        robot.ik(T[0], q_seed=np.full(6, np.inf))
    with pytest.raises(InputError,
                       match=r"q_seed: expected shape \(6,\) or \(1, 6\), got \(5,\)"):
        robot.ik(T[0], q_seed=np.zeros(5))
    with pytest.raises(InputError, match="chunk_size"):
        robot.ik_batch(T, chunk_size=0)
    assert robot.ik_batch(T[0])[0].shape[0] == 1  # one pose as a batch of one


# --------------------------------------------------------------------------------------------
# Memory


def test_a_million_poses_run_within_bounded_memory(load_robot):
    """10^6 IRB 1200 poses: streamed chunk by chunk with every copy, and as one dense batch of
    one solution per branch. Peak memory traced (numpy allocations) during each, no timing."""
    robot = load_robot("abb_irb1200_7_70")
    unique = robot.fk(robot.table.random_q(1000, np.random.default_rng(15)))
    T = np.tile(unique, (1000, 1, 1))  # (10^6, 4, 4), 128 MB, before tracing starts
    per_pose = robot.ik_batch(unique, copies=True)[1].sum(axis=1)
    tracemalloc.start()
    try:
        total = 0
        for start, part in robot.ik_batch_chunks(T, copies=True):
            total += int(part.valid.sum())
            rows = (start + np.arange(part.q.shape[0])) % len(unique)
            np.testing.assert_array_equal(part.valid.sum(axis=1), per_pose[rows])
        _, streamed_peak = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        Q, _ = robot.ik_batch(T, copies=False)
        _, dense_peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert total == int(per_pose.sum()) * 1000
    print(f"\n10^6 poses: streamed peak {streamed_peak / 2**20:.0f} MiB, dense (copies=False) "
          f"peak {dense_peak / 2**20:.0f} MiB for a {Q.nbytes / 2**20:.0f} MiB result")
    assert streamed_peak < 128 * 2**20
    n_branches = len(robot.ik_solver.branch_labels)
    # q, valid, flags, branch, residuals (B wide) and the per-branch work arrays (as wide)
    result = 2 * len(T) * n_branches * (8 * robot.dof + 20)
    assert dense_peak < result + 64 * 2**20


def test_streaming_a_ur_arm_with_every_copy_stays_small(load_robot):
    """UR5: 256 and more solutions per pose with every copy; 10^5 poses streamed with the default
    chunk size hold about 64 MiB of results at a time (the dense result would be ~1.2 GiB)."""
    robot = load_robot("ur5")
    unique = robot.fk(robot.table.random_q(1000, np.random.default_rng(17)))
    T = np.tile(unique, (100, 1, 1))
    tracemalloc.start()
    try:
        total = sum(int(part.valid.sum()) for _, part in robot.ik_batch_chunks(T, copies=True))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert total == int(robot.ik_batch(unique, copies=True)[1].sum()) * 100
    print(f"\n10^5 UR5 poses, every copy ({total / len(T):.0f} per pose), streamed: peak "
          f"{peak / 2**20:.0f} MiB")
    assert peak < 128 * 2**20


def test_copies_nearest_zero_outside_the_principal_range_match_ik(load_robot):
    """IRB 1200, joint 3 in [-200, 70] deg: poses with q3 below -180 deg have a wrapped
    (principal) value above 70 deg, so copies=False keeps a 2pi copy of it. ik_batch gives the
    same rows as ik, each exact."""
    robot = load_robot("abb_irb1200_7_70")
    rng = np.random.default_rng(23)
    q = robot.table.random_q(64, rng)
    q[:, 2] = rng.uniform(np.radians(-199.0), np.radians(-181.0), len(q))
    T = robot.fk(q)
    batch = robot.ik_batch_detailed(T, copies=False)
    assert (batch.q[..., 2][batch.valid] < -np.pi).any()
    for i in range(len(T)):
        solutions = robot.ik(T[i], copies=False)
        keep = batch.valid[i]
        np.testing.assert_array_equal(solutions.q, batch.q[i][keep])
        if len(solutions):
            position, rotation = pose_error(robot.fk(solutions.q),
                                            np.broadcast_to(T[i], (len(solutions), 4, 4)))
            assert position.max() <= 1e-9 and rotation.max() <= 1e-9
