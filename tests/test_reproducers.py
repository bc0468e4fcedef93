"""Costs and interrupts (issue 27, items 3 and 5): the reproducers d05 (memory of large
batches) and d10 (Ctrl-C) of issue 27, and the band within which an OPW file is
written in the plain form MoveIt reads.

Memory is traced with tracemalloc (numpy reports its allocations to it); no test asserts a time
(scripts/bench_fk.py measures it).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import dhkin
from dhkin import memory
from dhkin.cli_input import interrupted_text, path_states
from dhkin.errors import InputError
from dhkin.opw import PLAIN_FORM_BAND, opw_fk, opw_parameters
from dhkin.opw_compare import read_opw_file
from dhkin.opw_yaml import export_opw
from dhkin.transforms import pose_error, rot_x

# --------------------------------------------------------------------------------------------
# d05: memory of large batches


def test_d05_fk_of_a_million_joint_vectors_within_twice_its_output(load_robot) -> None:
    """robot.fk of 10^6 vectors: numpy's peak during the call at most twice the result (it was
    18 times: 2.3 GB for 128 MB)."""
    robot = load_robot("ur5")
    q = robot.table.random_q(1_000_000, np.random.default_rng(0))
    reference = robot.fk(q[:1000])
    tracemalloc.start()
    try:
        T = robot.fk(q)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= 2 * T.nbytes, f"peak {peak / 1e6:.0f} MB for {T.nbytes / 1e6:.0f} MB"
    np.testing.assert_array_equal(T[:1000], reference)  # chunking changes no bit


def test_d05_ik_batch_with_every_copy_is_sized_before_it_allocates(
        load_robot, monkeypatch: pytest.MonkeyPatch) -> None:
    """ik_batch(copies=True) of poses whose widest result exceeds the memory available is an
    InputError naming the size and ik_batch_chunks, raised before anything is allocated; at
    exactly the memory available it runs (the bound's edge)."""
    robot = load_robot("ur5")
    T = robot.fk(robot.table.random_q(20, np.random.default_rng(1)))
    needed = robot.batch_memory(len(T))
    assert needed == 2 * 20 * 8 * 3**5 * 2 * (8 * 6 + 20)  # 8 branches; +-2 turns: 3 copies
    monkeypatch.setattr(memory, "available_memory", lambda: needed)
    _, valid = robot.ik_batch(T, copies=True)
    assert valid.any(axis=1).all()
    monkeypatch.setattr(memory, "available_memory", lambda: needed - 1)
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as caught:
            robot.ik_batch(T, copies=True)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    text = str(caught.value)
    assert text.startswith(f"T: ik_batch with copies=True of 20 poses may need "
                           f"{needed / 1e9:.3g} GB (robot.batch_memory), more than the ")
    assert "robot.ik_batch_chunks(T, copies=True)" in text
    assert peak < needed / 10
    # Without copies, or streamed, nothing is refused.
    assert robot.ik_batch(T)[1].any(axis=1).all()
    assert sum(int(part.valid.sum()) for _, part in robot.ik_batch_chunks(T, copies=True)) \
        == int(valid.sum())


def test_d05_the_reproducers_batch_is_refused_here(load_robot) -> None:
    """10^5 UR5 poses with every copy: the widest result (53 GB) exceeds what this machine
    has, and the answer is the one-line error, at once (no poses are solved)."""
    robot = load_robot("ur5")
    T = np.broadcast_to(np.eye(4), (100_000, 4, 4))
    available = memory.available_memory()
    assert available is not None and robot.batch_memory(100_000) > available
    with pytest.raises(InputError, match="ik_batch_chunks"):
        robot.ik_batch(T, copies=True)


# --------------------------------------------------------------------------------------------
# d10: Ctrl-C

IK_MODULE = '''
import pathlib
import time

import dhkin

ROBOT = dhkin.load("ur5")
MARK = pathlib.Path(__file__).with_name("started")


def ik(T):
    """dhkin's IK, slowed down (the run outlasts the test's signal), marking its start."""
    MARK.touch()
    time.sleep(0.05)
    return ROBOT.ik(T).q
'''


def _interrupt_at_its_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_d10_ctrl_c_is_one_line_and_leaves_the_outputs(tmp_path: Path) -> None:
    """SIGINT while `dhkin validate` runs: one line naming the outputs left as they were, exit
    130, the old files intact (before: a 20-60 line traceback)."""
    (tmp_path / "slow_ik.py").write_text(IK_MODULE)
    report, failures = tmp_path / "v.json", tmp_path / "f.json"
    report.write_text("OLD")
    environment = dict(os.environ, PYTHONPATH=str(tmp_path))
    # Ctrl-C at a terminal: the command starts with SIGINT at its default action. An ignored
    # SIGINT is inherited across exec (a shell's background job, an xdist worker), and Python
    # then leaves it ignored: the signal below would be lost and the run go on to its end.
    process = subprocess.Popen(
        [sys.executable, "-m", "dhkin.cli", "validate", "ur5", "--ik", "slow_ik:ik", "-n",
         "2000", "--json", str(report), "--failures", str(failures), "--force"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment,
        preexec_fn=_interrupt_at_its_default)
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "started").exists():
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.05)
        time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 130
    assert err == f"dhkin: interrupted; {report}, {failures} left as they were\n"
    assert report.read_text() == "OLD" and not failures.exists()


def test_the_interrupt_line_names_what_was_written(tmp_path: Path) -> None:
    kept, written, absent = tmp_path / "a.json", tmp_path / "b.md", tmp_path / "c.json"
    kept.write_text("a")
    written.write_text("b")
    paths = [str(kept), str(written), str(absent)]
    before = path_states(paths)
    os.utime(written, ns=(0, 0))
    assert interrupted_text(paths, before) == \
        f"interrupted; {written} written; {kept}, {absent} left as they were"
    assert interrupted_text([], []) == "interrupted"


# --------------------------------------------------------------------------------------------
# Item 3: the plain form within its band


def tilted_kuka(rotation: float = 0.0, shift: float = 0.0) -> dhkin.DHTable:
    """The KR 6 R900 sixx with tool0 tilted by ``rotation`` rad about its x axis and moved
    ``shift`` m along its x axis (across axis 6)."""
    table = dhkin.load("kuka_kr6r900sixx").table
    offset = rot_x(rotation)
    offset[0, 3] = shift
    return replace(table, tool=table.tool @ offset)


@pytest.mark.parametrize(("rotation", "shift", "plain"), [
    (PLAIN_FORM_BAND[1] * (1 - 1e-4), 0.0, True),
    (PLAIN_FORM_BAND[1] * (1 + 1e-4), 0.0, False),
    (0.0, PLAIN_FORM_BAND[0] * (1 - 1e-4), True),
    (0.0, PLAIN_FORM_BAND[0] * (1 + 1e-4), False),
    (3.3116036843327394e-07, 0.0, True),  # the MH12/GP12 URDF's rounded tool0 rpy
])
def test_the_plain_form_band_at_its_edge(rotation: float, shift: float, plain: bool,
                                         tmp_path: Path) -> None:
    """Within PLAIN_FORM_BAND the file has no dhkin_fixed_frames and says how far MoveIt's FK
    is from the table's (measured here: at most the band); outside it the frames are given and
    the file's FK (frames included) is the table's to 1e-12."""
    table = tilted_kuka(rotation, shift)
    path = export_opw(table, tmp_path)
    text = path.read_text()
    assert ("dhkin_fixed_frames:" not in text) == plain
    written = read_opw_file(path, opw_parameters(table))
    q = table.random_q(300, np.random.default_rng(2))
    position, angle = pose_error(written.base @ opw_fk(written, q) @ written.tool, table.fk(q))
    if plain:
        assert "within the band 1e-09 m, 1e-06 rad: written as OPW base = base_link" in text
        assert position.max() <= PLAIN_FORM_BAND[0] + 1e-15
        assert angle.max() <= PLAIN_FORM_BAND[1]
    else:
        assert "The OPW frames are not base_link and tool0" in text
        assert position.max() <= 1e-12 and angle.max() <= 1e-12
