"""The moved poses of the general 6R solver's ill-conditioned poses (:mod:`dhkin.ik.general6r`;
:func:`dhkin.ik.compiled.general6r.all_candidates`): a small rigid motion of DH frame 0 by
which such a pose is moved, solved, and followed back (docs/general6r.md, "Every root"). One
direction: where the motion turns a pair of roots near a fold into a complex pair, the pair's
start (its real part) reaches one of them and the fold partner probed from it the other
(:func:`dhkin.ik.compiled.general6r_roots.fold_partner`); measured on 1,000 ill-conditioned
special-angle poses of the CRX-10iA and the tilted UR5, the second, opposite motion found no
root the first missed and cost half the time of such a pose.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

#: Size of the moved poses of an ill-conditioned pose (:func:`moves`; rad, and units of the
#: model's length scale). Where M(x) is singular for every x at a pose (special poses of the
#: tilted UR5 in every arrangement, of the CRX-10iA in both its regular ones), a pose moved by
#: e has a regular, but e-close to singular, matrix polynomial: its eigenvalues keep the
#: regular part's (the roots), and each regular root of sigma moves by ~e / sigma, followed
#: back (:func:`dhkin.ik.compiled.general6r_track.track`). Measured on the ill-conditioned
#: special-angle poses of the CRX-10iA and the tilted UR5 (182 of 800) with scipy's QZ, every
#: root was found for e from 1e-6 to 1e-3 (one lost at 1e-7, two at 1e-2). The kernels take
#: the moved pencil's null vectors by inverse iteration, which near a singular point confuses
#: the root's null vector with the pencil's near-null directions (~e^2): at e = 1e-4 a tilted
#: UR5 root (sigma 4.6e-4, 0.1 rad from a singular one) and a CRX-10iA singular root were
#: lost, at 1e-3 neither: the top of the measured range.
PERTURBATION = 1e-3


#: The direction of the moved poses: a fixed twist (rotation, translation) with no special
#: component.
PERTURBATION_TWIST = np.array([0.3, -0.5, 0.7, 0.2, 0.4, -0.1]) / math.sqrt(1.04)


def moves(scale: float) -> NDArray[np.float64]:
    """The motion (1, 6) PERTURBATION twist: a rotation vector (rad) and a translation (in
    units of ``scale`` metres), applied on the left of DH frame 0's poses."""
    out = np.empty((1, 6))
    out[0, :3] = PERTURBATION * PERTURBATION_TWIST[:3]
    out[0, 3:] = PERTURBATION * scale * PERTURBATION_TWIST[3:]
    return out


def perturbations(scale: float) -> NDArray[np.float64]:
    """The rigid motions (1, 4, 4) of :func:`moves`: the rotation of the rotation vector
    (Rodrigues) and the translation."""
    out = np.tile(np.eye(4), (1, 1, 1))
    for index, move in enumerate(moves(scale)):
        angle = float(np.linalg.norm(move[:3]))
        axis = move[:3] / angle
        K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                      [-axis[1], axis[0], 0.0]])
        out[index, :3, :3] = np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K
        out[index, :3, 3] = move[3:]
    return out


#: Starts of the multistart fallback of an ill-conditioned pose (with its moved poses,
#: :func:`dhkin.ik.compiled.general6r.all_candidates`): near a highly degenerate singular set
#: (a CRX-10iA pose at q = (-90, -90, 90, 90, 0, 90) deg: a stretched arm, q5 = 0) the moved
#: poses' own eigenproblems lose the roots they have there, and 32 fixed starts find them
#: (measured down to 32 there). They cost ~1 ms, on such poses only.
FALLBACK_STARTS = 32


def fallback_starts(lower: NDArray[np.float64], upper: NDArray[np.float64]
                    ) -> NDArray[np.float64]:
    """:data:`FALLBACK_STARTS` fixed joint vectors (seeded generator), uniform over the joint
    ranges where they are finite and narrower than a turn, over (-pi, pi] elsewhere."""
    rng = np.random.default_rng(26)
    low = np.where(np.isfinite(lower) & (upper - lower < 2.0 * math.pi), lower, -math.pi)
    high = np.where(np.isfinite(upper) & (upper - lower < 2.0 * math.pi), upper, math.pi)
    return np.ascontiguousarray(rng.uniform(low, high, size=(FALLBACK_STARTS, 6)))
