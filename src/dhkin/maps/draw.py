"""Drawing: the workspace slice and two joint slices in one PNG, and what a figure shows in words
(computation lives in :mod:`.workspace` and :mod:`.joints`).
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from dhkin.errors import InputError
from dhkin.files import check_output, write_file
from dhkin.maps.branches import (
    AXIS_NAMES,
    DEFAULT_JOINT_RESOLUTION,
    DEFAULT_RESOLUTION,
    PLANES,
    Array,
)
from dhkin.maps.joints import JointSlice, joint_slice
from dhkin.maps.workspace import WorkspaceSlice, workspace_slice
from dhkin.singularity import (
    KINDS,
    singularity_model,
)

if TYPE_CHECKING:
    from dhkin.arm import Arm

#: Figure size (inches) and resolution: the PNG is FIGURE_SIZE * DPI pixels.
FIGURE_SIZE = (18.0, 6.4)


DPI = 100


KIND_STYLE: dict[str, dict[str, str]] = {
    "wrist": {"color": "#e41a1c", "marker": "o", "label": "wrist singular"},
    "elbow": {"color": "#00e5ff", "marker": "s", "label": "elbow singular (stretched/folded)"},
    "shoulder": {"color": "#ff8c00", "marker": "D", "label": "shoulder singular"},
}


MEASURE_LABEL = "Yoshikawa manipulability |det J| (m$^3$)"


@dataclass(frozen=True)
class SingularityMaps:
    """What :func:`draw_maps` computed and drew."""

    workspace: WorkspaceSlice
    joint_slices: tuple[JointSlice, ...]
    path: Path


def draw_maps(robot: Arm, output: str | Path, plane: str = "xz", offset: float = 0.0,
              rpy: Sequence[float] | None = None, resolution: int = DEFAULT_RESOLUTION,
              joint_resolution: int = DEFAULT_JOINT_RESOLUTION,
              q_fixed: ArrayLike | None = None, progress: bool = False,
              force: bool = False) -> SingularityMaps:
    """Compute a workspace slice and the q2-q3 and q3-q5 joint slices; write them as one PNG
    of FIGURE_SIZE * DPI pixels to ``output``. ``output`` is checked before anything is computed
    (:func:`dhkin.files.check_output`: its folder exists and is writable; an existing file is
    replaced only with ``force``) and written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(output)
    if path.suffix.lower() != ".png":
        raise InputError(f"output: expected a .png file name, got {str(output)!r}", field="output")
    check_output(path, force=force)
    workspace = workspace_slice(robot, plane, offset, rpy, resolution=resolution,
                                progress=progress)
    slices = (joint_slice(robot, (2, 3), q_fixed, joint_resolution),
              joint_slice(robot, (3, 5), q_fixed, joint_resolution))
    figure, axes = plt.subplots(1, 3, figsize=FIGURE_SIZE, dpi=DPI,
                                gridspec_kw={"width_ratios": [1.25, 1, 1]})
    _draw_workspace(axes[0], figure, workspace)
    for ax, data in zip(axes[1:], slices, strict=True):
        _draw_joint_slice(ax, figure, robot, data)
    model = singularity_model(robot)
    figure.suptitle(f"{robot.name} ({model.family.replace('_', ' ')}): manipulability "
                    f"|det J| and singular loci", fontsize=15)
    figure.tight_layout(rect=(0, 0, 1, 0.95))
    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=DPI)
    plt.close(figure)
    write_file(path, image.getvalue(), force=force)
    return SingularityMaps(workspace=workspace, joint_slices=slices, path=path)


def _draw_workspace(ax, figure, data: WorkspaceSlice) -> None:
    from matplotlib.lines import Line2D

    iu, iv, normal = PLANES[data.plane]
    image = ax.pcolormesh(data.u, data.v, np.ma.masked_invalid(data.manipulability),
                          shading="nearest", cmap="viridis")
    colorbar = figure.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(MEASURE_LABEL + ", best over IK solutions")
    ax.contour(data.u, data.v, data.reachable.astype(float), levels=[0.5], colors="0.35",
               linewidths=0.8)
    handles = [Line2D([], [], color="0.35", lw=0.8, label="reach boundary (blank: unreachable)")]
    uu, vv = np.meshgrid(data.u, data.v)
    for kind in ("shoulder", "elbow", "wrist"):  # wrist loci drawn on top
        if kind not in data.loci or not data.loci[kind].any():
            continue
        style = KIND_STYLE[kind]
        mask = data.loci[kind]
        ax.scatter(uu[mask], vv[mask], s=7, c=style["color"], marker=style["marker"],
                   linewidths=0)
        handles.append(Line2D([], [], color=style["color"], marker=style["marker"], ls="",
                              label=style["label"]))
    ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.85)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{AXIS_NAMES[iu]} (m, base_link)")
    ax.set_ylabel(f"{AXIS_NAMES[iv]} (m, base_link)")
    rpy_deg = ", ".join(f"{math.degrees(a):.0f}" for a in data.rpy)
    ax.set_title(f"Workspace slice {AXIS_NAMES[normal]} = {data.offset:g} m, tool0 rpy "
                 f"({rpy_deg}) deg\n(tool0 z along {_direction_text(data.rotation[:, 2])})",
                 fontsize=11)


def _direction_text(vector: Array) -> str:
    parts = [f"{value:+.2f}{name}" for value, name in zip(vector, AXIS_NAMES, strict=True)
             if abs(value) > 5e-3]
    return " ".join(parts)


def _joint_label(robot: Arm, joint: int) -> tuple[str, float]:
    info = robot.table.joints[joint - 1]
    if info.is_revolute:
        return f"q{joint} {info.name} (deg)", 180.0 / math.pi
    return f"q{joint} {info.name} (m)", 1.0


def _draw_joint_slice(ax, figure, robot: Arm, data: JointSlice) -> None:
    from matplotlib.lines import Line2D

    u_label, u_scale = _joint_label(robot, data.joints[0])
    v_label, v_scale = _joint_label(robot, data.joints[1])
    u, v = data.u * u_scale, data.v * v_scale
    image = ax.pcolormesh(u, v, data.manipulability, shading="nearest", cmap="viridis")
    colorbar = figure.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(MEASURE_LABEL)
    handles = []
    for kind in KINDS:
        if kind not in data.signed:
            continue
        values = data.signed[kind]
        if not (np.nanmin(values) <= 0 <= np.nanmax(values)):
            continue
        style = KIND_STYLE[kind]
        dashes = "--" if kind == "shoulder" else "-"
        ax.contour(u, v, values, levels=[0.0], colors=style["color"], linewidths=1.8,
                   linestyles=dashes)
        handles.append(Line2D([], [], color=style["color"], lw=1.8, ls=dashes,
                              label=style["label"]))
    if handles:
        ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.85)
    ax.set_xlabel(u_label)
    ax.set_ylabel(v_label)
    others = [k for k in range(1, robot.dof + 1) if k not in data.joints]
    fixed = ", ".join(f"q{k} = {_format_joint(robot, k, data.q_fixed[k - 1])}" for k in others)
    ax.set_title(f"Joint slice q{data.joints[0]}-q{data.joints[1]}\n({fixed})", fontsize=11)


def _format_joint(robot: Arm, joint: int, value: float) -> str:
    if robot.table.joints[joint - 1].is_revolute:
        return f"{math.degrees(value):.0f} deg"
    return f"{value:.3g} m"


def describe(maps: SingularityMaps) -> str:
    """What a figure shows, in words and counts."""
    workspace = maps.workspace
    normal = PLANES[workspace.plane][2]
    rpy_deg = ", ".join(f"{math.degrees(a):.1f}" for a in workspace.rpy)
    cells = workspace.manipulability.size
    reachable = int(workspace.reachable.sum())
    best = float(np.nanmax(workspace.manipulability)) if reachable else float("nan")
    lines = [f"wrote {maps.path} ({int(FIGURE_SIZE[0] * DPI)} x {int(FIGURE_SIZE[1] * DPI)} px)",
             f"workspace slice {AXIS_NAMES[normal]} = {workspace.offset:g} m, tool0 rpy "
             f"({rpy_deg}) deg: {reachable} of {cells} cells reachable, best |det J| "
             f"{best:.4g} m^3",
             "  cells on singular loci: " + ", ".join(
                 f"{kind} {int(mask.sum())}" for kind, mask in workspace.loci.items())]
    for data in maps.joint_slices:
        lines.append(f"joint slice q{data.joints[0]}-q{data.joints[1]}: max |det J| "
                     f"{float(np.max(data.manipulability)):.4g} m^3; cells on loci: "
                     + ", ".join(f"{kind} {int(mask.sum())}" for kind, mask in data.loci.items()))
    return "\n".join(lines)
