"""Manipulability maps (issue 5, item 4): the data behind the pictures, checked against IK and
the analysis, and the PNG they go into.

The grids are tested, not the pixels: unreachable cells are NaN exactly where dhkin's IK (the
full one, within the real joint limits) has no solution; reachable cells hold the best |det J|
from Pinocchio over the IK solutions; cells marked as on a singular locus have the locus within
reach (a fine 1-D scan, or a bisection to the workspace boundary, finds a singular pose within
1.5 cells), and known loci are marked where the geometry puts them.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from numpy.typing import NDArray

import dhkin
from dhkin.errors import FamilyError, InputError
from dhkin.maps import (
    DPI,
    FIGURE_SIZE,
    JointSlice,
    WorkspaceSlice,
    draw_maps,
    joint_slice,
    workspace_slice,
)
from dhkin.singularity import (
    DEFAULT_THRESHOLDS,
    SingularityModel,
    singularity_model,
    singularity_report,
)

RESOLUTION = 61
ROBOTS = ["abb_irb1200_7_70", "ur5"]
#: Lines are scanned this finely (m); a zero shows as a V: a sample below both neighbours and
#: below a quarter of their sum (the V's zero within half a step of it).
SCAN_STEP = 0.002


@pytest.fixture(scope="module")
def slices() -> dict[str, WorkspaceSlice]:
    return {name: workspace_slice(dhkin.load(name), resolution=RESOLUTION) for name in ROBOTS}


def png_size(path) -> tuple[int, int]:
    with open(path, "rb") as file:
        header = file.read(24)
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", header[16:24])


def solve(robot: dhkin.Robot, poses: NDArray[np.float64],
          kind: str) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Per pose, the smallest distance to ``kind`` over all IK solutions within the limits (inf
    where there is none) and the number of solutions, from robot.ik_batch (not the map's own
    solver)."""
    Q, valid = robot.ik_batch(poses)
    out = np.full(len(poses), np.inf)
    rows, slots = np.nonzero(valid)
    if rows.size:
        distance = singularity_model(robot).factors(Q[rows, slots]).distance(kind)
        np.minimum.at(out, rows, distance)
    return out, valid.sum(axis=1)


def smallest_distances(robot: dhkin.Robot, poses: NDArray[np.float64],
                       kind: str) -> NDArray[np.float64]:
    return solve(robot, poses, kind)[0]


def poses_at(data: WorkspaceSlice, u: NDArray[np.float64],
             v: NDArray[np.float64]) -> NDArray[np.float64]:
    T = np.repeat(data.pose(0, 0)[None], len(u), axis=0)
    T[:, 0, 3] = u  # plane "xz": u = x, v = z, y = offset
    T[:, 2, 3] = v
    T[:, 1, 3] = data.offset
    return T


def cell_size(data: WorkspaceSlice) -> float:
    return float(data.u[1] - data.u[0])


# --------------------------------------------------------------------------------------------
# Reachability and values


@pytest.mark.parametrize("name", ROBOTS)
def test_blank_cells_are_exactly_the_unreachable_ones(name: str, slices, load_robot) -> None:
    robot = load_robot(name)
    data = slices[name]
    assert data.manipulability.shape == (RESOLUTION, RESOLUTION)
    reachable = data.reachable
    assert 0.2 < reachable.mean() < 0.8  # the extent covers the reach, with blank around it
    np.testing.assert_array_equal(reachable, data.solutions > 0)
    rows, columns = np.indices(reachable.shape)
    _, valid = robot.ik_batch(np.array([data.pose(r, c) for r, c in
                                        zip(rows.ravel(), columns.ravel(), strict=True)]))
    np.testing.assert_array_equal(valid.any(axis=1).reshape(reachable.shape), reachable)
    for kind in data.distances:
        assert np.all(np.isnan(data.distances[kind][~reachable]))
        assert not data.loci[kind][~reachable].any()


@pytest.mark.parametrize("name", ROBOTS)
def test_cell_values_are_the_best_pinocchio_manipulability(name: str, slices,
                                                           load_robot) -> None:
    """On 25 reachable cells: the value is the largest |det J| (Pinocchio) over robot.ik's
    solutions, and the number of distinct branches is that of robot.ik's configurations."""
    robot = load_robot(name)
    data = slices[name]
    ref = robot.reference()
    rng = np.random.default_rng(5)
    cells = np.argwhere(data.reachable)
    for r, c in cells[rng.choice(len(cells), 25, replace=False)]:
        solutions = robot.ik(data.pose(r, c))
        best = max(abs(np.linalg.det(ref.jacobian(q))) for q in solutions.q)
        assert data.manipulability[r, c] == pytest.approx(best, rel=1e-9)
        branches = {tuple(sorted(conf.labels.items())) for conf in solutions.configurations}
        assert data.solutions[r, c] == len(branches)


# --------------------------------------------------------------------------------------------
# Singular loci


def scan_zeros(distance: NDArray[np.float64], count: NDArray[np.int64]) -> list[int]:
    """Samples of a finely scanned distance where it has a V-shaped zero (see SCAN_STEP), with
    the same number of IK solutions on both sides (where a branch appears at a joint limit the
    smallest distance jumps, which is no zero)."""
    return [i for i in range(1, len(distance) - 1)
            if count[i - 1] == count[i] == count[i + 1] > 0
            and distance[i] <= min(distance[i - 1], distance[i + 1])
            and distance[i] <= 0.25 * (distance[i - 1] + distance[i + 1])]


def locus_within_reach(robot: dhkin.Robot, data: WorkspaceSlice, row: int, column: int,
                       kind: str) -> bool:
    """Whether a singular pose of ``kind`` lies on the lines through a cell's centre along x
    and z, 1.5 cells each way: a V-shaped zero of the distance sampled every SCAN_STEP; or,
    where the number of IK solutions changes between two samples (a boundary, or two branches
    merging and ending as at full stretch), at the last point before the change (30
    bisections) within the default threshold, or a V-shaped zero on 25 samples from one step
    before the change to that point."""
    h = 1.5 * cell_size(data)
    offsets = np.arange(-h, h + 1e-12, SCAN_STEP)
    u0, v0 = data.u[column], data.v[row]
    for du, dv in ((1.0, 0.0), (0.0, 1.0)):
        points = np.stack([u0 + du * offsets, v0 + dv * offsets], axis=1)
        distance, count = solve(robot, poses_at(data, points[:, 0], points[:, 1]), kind)
        if scan_zeros(distance, count):
            return True
        for i in np.flatnonzero(count[:-1] != count[1:]):
            more, fewer = (i, i + 1) if count[i] > count[i + 1] else (i + 1, i)
            a, b = points[more], points[fewer]
            for _ in range(30):
                middle = 0.5 * (a + b)
                _, n = solve(robot, poses_at(data, middle[:1], middle[1:]), kind)
                if n[0] == count[more]:
                    a = middle
                else:
                    b = middle
            start = points[more] - (points[fewer] - points[more])
            fine = start + np.linspace(0.0, 1.0, 25)[:, None] * (a - start)
            fine_distance, fine_count = solve(robot, poses_at(data, fine[:, 0], fine[:, 1]),
                                              kind)
            if fine_distance[-1] <= DEFAULT_THRESHOLDS.of(kind) \
                    or scan_zeros(fine_distance, fine_count):
                return True
    return False


def boundary_point_distance(robot: dhkin.Robot, data: WorkspaceSlice, row: int, column: int,
                            kind: str) -> float:
    """Distance to ``kind`` at the workspace boundary between a reachable cell and its first
    unreachable 4-neighbour, found by 40 bisections with robot.ik."""
    for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        r, c = row + dr, column + dc
        if 0 <= r < RESOLUTION and 0 <= c < RESOLUTION and not data.reachable[r, c]:
            break
    else:
        raise AssertionError("not a boundary cell")
    inside = np.array([data.u[column], data.v[row]])
    outside = np.array([data.u[c], data.v[r]])
    for _ in range(40):
        middle = 0.5 * (inside + outside)
        if robot.ik(poses_at(data, middle[:1], middle[1:])[0]):
            inside = middle
        else:
            outside = middle
    return float(smallest_distances(robot, poses_at(data, inside[:1], inside[1:]), kind)[0])


@pytest.mark.parametrize("name", ROBOTS)
def test_marked_interior_cells_have_the_locus_within_reach(name: str, slices,
                                                           load_robot) -> None:
    """Up to 5 marked interior cells per kind: a singular pose lies within 1.5 cells along x or
    z (found independently with robot.ik)."""
    robot = load_robot(name)
    data = slices[name]
    rng = np.random.default_rng(11)
    checked = 0
    for kind, mask in data.loci.items():
        cells = np.argwhere(mask & ~data.boundary)
        for r, c in cells[rng.permutation(len(cells))[:5]]:
            assert locus_within_reach(robot, data, r, c, kind), (kind, r, c)
            checked += 1
    assert checked >= 8


@pytest.mark.parametrize("name", ROBOTS)
def test_marked_boundary_cells_end_at_a_singularity(name: str, slices, load_robot) -> None:
    """Marked boundary cells: at the boundary point (bisection with robot.ik) the distance to
    that kind is within the default threshold, or (a locus meeting the boundary) a singular pose
    lies within 1.5 cells inside; unmarked boundary cells: at the boundary point no kind is
    within its threshold (the boundary there is set by joint limits)."""
    robot = load_robot(name)
    data = slices[name]
    rng = np.random.default_rng(12)
    marked_any = np.zeros_like(data.boundary)
    at_boundary = 0
    for kind, mask in data.loci.items():
        marked_any |= mask & data.boundary
        cells = np.argwhere(mask & data.boundary)
        for r, c in cells[rng.permutation(len(cells))[:4]]:
            if boundary_point_distance(robot, data, r, c, kind) <= DEFAULT_THRESHOLDS.of(kind):
                at_boundary += 1
            else:
                assert locus_within_reach(robot, data, r, c, kind), (kind, r, c)
    assert at_boundary >= 4
    plain = np.argwhere(data.boundary & ~marked_any)
    for r, c in plain[rng.permutation(len(plain))[:4]]:
        for kind in data.loci:
            assert boundary_point_distance(robot, data, r, c, kind) > \
                DEFAULT_THRESHOLDS.of(kind), (kind, r, c)


@pytest.mark.parametrize("name", ROBOTS)
def test_wrist_loci_crossing_a_row_are_marked(name: str, slices, load_robot) -> None:
    """Converse: scan rows finely with robot.ik; every V-shaped zero of the wrist distance
    (|sin q5|) has a wrist-marked cell within 1.5 cells in that row."""
    robot = load_robot(name)
    data = slices[name]
    found = 0
    for row in (RESOLUTION // 3, RESOLUTION // 2, 2 * RESOLUTION // 3):
        x = np.arange(data.u[0], data.u[-1], SCAN_STEP)
        z = np.full(len(x), data.v[row])
        zeros = scan_zeros(*solve(robot, poses_at(data, x, z), "wrist"))
        marked = data.u[data.loci["wrist"][row]]
        for i in zeros:
            assert marked.size and np.min(np.abs(marked - x[i])) <= 1.5 * cell_size(data), \
                (row, x[i])
        found += len(zeros)
    assert found >= 2  # the default slice crosses wrist loci


def test_irb1200_shoulder_locus_is_the_vertical_line_x_equals_d6(slices) -> None:
    """Tool0 z along +x: the wrist centre is at p - 0.082 m x, on axis 1 exactly when
    x = d6 = 0.082 m. Every interior row crossing it marks a shoulder cell within one cell, and
    every shoulder mark is within 1.5 cells of it."""
    data = slices["abb_irb1200_7_70"]
    d6 = 0.082
    h = cell_size(data)
    column = int(np.argmin(np.abs(data.u - d6)))
    marked_columns = np.argwhere(data.loci["shoulder"])[:, 1]
    assert marked_columns.size > 5
    assert np.all(np.abs(data.u[marked_columns] - d6) <= 1.5 * h)
    interior = data.reachable[:, column - 2] & data.reachable[:, column + 2] \
        & data.reachable[:, column]
    assert interior.sum() > 5
    for row in np.flatnonzero(interior):
        assert data.loci["shoulder"][row, column - 1:column + 2].any(), row


def test_ur5_wrist_loci_are_the_vertical_lines_the_geometry_predicts(slices, load_robot) -> None:
    """Offset wrist, tool0 z = t = (x + y)/sqrt 2: singular when axis 4 (parallel to axis 2,
    horizontal) is parallel to t. The wrist point then lies (+-d4) along t from the arm plane and
    tool0 another +-d6 along t, so tool0 in y = 0 has x = sqrt(2) (+-d4 +- d6): vertical lines.
    Every interior wrist mark is within 1.5 cells of one, and the line at x = sqrt(2)(d4 + d6)
    is marked in every interior row that crosses it."""
    data = slices["ur5"]
    rows = load_robot("ur5").table.joints
    d4, d6 = rows[3].d, rows[5].d
    lines = math.sqrt(2) * np.array([d4 + d6, d4 - d6, -d4 + d6, -d4 - d6])
    h = cell_size(data)
    marks = np.argwhere(data.loci["wrist"] & ~data.boundary)
    assert len(marks) > 20
    assert np.all(np.min(np.abs(data.u[marks[:, 1], None] - lines[None]), axis=1) <= 1.5 * h)
    column = int(np.argmin(np.abs(data.u - lines[0])))
    interior = data.reachable[:, column - 2] & data.reachable[:, column + 2]
    assert interior.sum() > 20
    for row in np.flatnonzero(interior):
        assert data.loci["wrist"][row, column - 1:column + 2].any(), row


def test_ur5_slot_around_axis_1_is_shoulder_singular(slices) -> None:
    """The UR5's wrist point cannot come closer to axis 1 than the lateral offset: the vertical
    slot in the slice is unreachable and its walls are shoulder loci."""
    data = slices["ur5"]
    middle = RESOLUTION // 2
    row = data.reachable[middle]
    gaps = np.flatnonzero(~row[1:-1]) + 1
    slot = gaps[(np.abs(data.u[gaps]) < 0.3)]
    assert slot.size >= 2
    walls = [slot.min() - 1, slot.max() + 1]
    assert all(data.loci["shoulder"][middle, wall] for wall in walls)


# --------------------------------------------------------------------------------------------
# Joint slices


@pytest.mark.parametrize("name", ROBOTS)
def test_joint_slices_mark_the_exact_loci(name: str, load_robot) -> None:
    """q2-q3 and q3-q5 slices: elbow marks on the rows/columns next to the analytic elbow angle
    (IRB 1200: q3 = atan2(-d4, a3); UR5: q3 = 0), wrist marks next to q5 = 0; each shoulder mark
    lies within one cell of a configuration that Pinocchio finds singular."""
    robot = load_robot(name)
    rows = robot.table.joints
    elbow_q3 = math.atan2(-rows[3].d, rows[2].a) if name.startswith("abb") else 0.0
    q23 = joint_slice(robot, (2, 3), resolution=91)
    q35 = joint_slice(robot, (3, 5), resolution=91)
    assert isinstance(q23, JointSlice)

    def near(values: NDArray[np.float64], target: float) -> set[int]:
        step = values[1] - values[0]
        return {int(i) for i in np.flatnonzero(np.abs(values - target) <= step)}

    elbow_rows = set(np.flatnonzero(q23.loci["elbow"].any(axis=1)).tolist())
    assert elbow_rows and elbow_rows <= near(q23.v, elbow_q3)
    assert q23.loci["elbow"].any(axis=0).all()  # the line crosses every q2 column
    elbow_columns = set(np.flatnonzero(q35.loci["elbow"].any(axis=0)).tolist())
    assert elbow_columns and elbow_columns <= near(q35.u, elbow_q3)
    wrist_rows = set(np.flatnonzero(q35.loci["wrist"].any(axis=1)).tolist())
    assert near(q35.v, 0.0) & wrist_rows
    assert all(abs(math.sin(q35.v[r])) <= math.sin(q35.v[1] - q35.v[0]) for r in wrist_rows)

    model = singularity_model(robot)
    marks = np.argwhere(q23.loci["shoulder"])
    assert len(marks) > 10
    for r, c in marks[:: max(1, len(marks) // 10)]:
        q = q23.q_fixed.copy()
        q[1], q[2] = q23.u[c], q23.v[r]
        exact = shoulder_zero_within_a_cell(model, q, q23.u[1] - q23.u[0])
        assert exact is not None, (r, c)
        assert singularity_report(robot, exact).sigma_min < 1e-12


def shoulder_zero_within_a_cell(model: SingularityModel, q: NDArray[np.float64],
                                step: float) -> NDArray[np.float64] | None:
    """An exactly shoulder-singular q within one cell of q along joint 2 (model.place) or
    joint 3 (bisection of the sign change of the shoulder factor), or None."""
    exact = model.place(q, "shoulder")
    if abs(exact[1] - q[1]) <= step:
        return exact
    for side in (-step, step):
        a, b = q.copy(), q.copy()
        b[2] += side
        fa, fb = model.factors(np.array([a, b])).shoulder
        if fa * fb > 0:
            continue
        for _ in range(60):
            middle = 0.5 * (a + b)
            fm = model.factors(middle).shoulder[0]
            a, b = (middle, b) if fa * fm > 0 else (a, middle)
            fa = model.factors(a).shoulder[0]
        return a
    return None


# --------------------------------------------------------------------------------------------
# Figure and command line


def test_figure_png_has_the_expected_size(tmp_path, load_robot) -> None:
    path = tmp_path / "ur5.png"
    maps = draw_maps(load_robot("ur5"), path, resolution=31, joint_resolution=41)
    assert maps.path == path
    assert png_size(path) == (int(FIGURE_SIZE[0] * DPI), int(FIGURE_SIZE[1] * DPI))
    assert path.stat().st_size > 20_000
    assert [s.joints for s in maps.joint_slices] == [(2, 3), (3, 5)]


def test_cli_map_writes_the_png_and_says_what_it_found(tmp_path, capsys) -> None:
    from dhkin.cli import main

    out = tmp_path / "abb.png"
    assert main(["map", "abb_irb1200_7_70", "-o", str(out), "--resolution", "31",
                 "--joint-resolution", "41", "--rpy", "0", "90", "0", "--deg",
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out}" in text
    assert "tool0 rpy (0.0, 90.0, 0.0) deg" in text
    assert "cells on singular loci: wrist" in text
    assert png_size(out) == (int(FIGURE_SIZE[0] * DPI), int(FIGURE_SIZE[1] * DPI))


def test_progress_bar_on_request(capsys, load_robot) -> None:
    workspace_slice(load_robot("abb_irb1200_7_70"), resolution=16, progress=True)
    assert "workspace IK" in capsys.readouterr().err


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"plane": "xx"}, "plane: expected one of"),
    ({"resolution": 3}, "resolution: expected an integer from 8"),
    ({"rpy": (0.0, 1.0)}, r"rpy: expected 3 finite angles"),
    ({"offset": float("nan")}, "offset: expected a finite distance"),
])
def test_bad_workspace_arguments(kwargs, message, load_robot) -> None:
    with pytest.raises(InputError, match=message):
        workspace_slice(load_robot("ur5"), **kwargs)


def test_bad_output_and_joint_arguments(tmp_path, load_robot) -> None:
    robot = load_robot("ur5")
    with pytest.raises(InputError, match=r"expected a \.png file name"):
        draw_maps(robot, tmp_path / "map.jpg")
    with pytest.raises(InputError, match="does not exist"):
        draw_maps(robot, tmp_path / "missing" / "map.png")
    with pytest.raises(InputError, match="two different joint numbers"):
        joint_slice(robot, (3, 3))
    with pytest.raises(FamilyError, match="no analytic singularity family"):
        workspace_slice(load_robot("planar_2r"))
