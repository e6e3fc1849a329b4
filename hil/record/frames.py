"""Plant truth (NED world, FRD body) -> the ENU/FLU convention of Foxglove's 3D panel.

Foxglove (like ROS REP 103) draws frames right-handed with z up: we publish the world frame
``world`` as ENU (x east, y north, z up) and the body frame ``base_link`` as FLU (x forward,
y left, z up). With ``R_EN`` the NED->ENU axis swap and ``R_BF`` the FLU->FRD flip,

    p_E = R_EN p_N = (p_N[1], p_N[0], -p_N[2])
    R_EF = R_EN R_NB R_BF            (quaternions: q_EF = q_EN * q_NB * q_BF)

``R_EN`` is a 180 deg turn about (1, 1, 0)/sqrt(2): q_EN = (0, 1/sqrt2, 1/sqrt2, 0);
``R_BF`` is a 180 deg turn about x: q_BF = (0, 1, 0, 0). Quaternions here are (w, x, y, z)
lists (Hamilton); Foxglove's are {x, y, z, w} objects.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from hil.plant.quat import mul

WORLD_FRAME = "world"  #: ENU
BODY_FRAME = "base_link"  #: FLU

_S = math.sqrt(0.5)
Q_EN: tuple[float, float, float, float] = (0.0, _S, _S, 0.0)
Q_BF: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 0.0)


def ned_to_enu(p_N: Sequence[float]) -> tuple[float, float, float]:
    """A NED vector (any unit) in ENU axes."""
    return (float(p_N[1]), float(p_N[0]), -float(p_N[2]))


def q_NB_to_q_EF(q_NB: Sequence[float]) -> tuple[float, float, float, float]:
    """Attitude (w, x, y, z) of FRD body in NED -> attitude of FLU body in ENU, normalised, w >= 0."""
    q_NB_f = (float(q_NB[0]), float(q_NB[1]), float(q_NB[2]), float(q_NB[3]))
    q = mul(mul(Q_EN, q_NB_f), Q_BF)
    n = math.sqrt(sum(v * v for v in q)) or 1.0
    if q[0] < 0:  # same rotation; the w >= 0 hemisphere reads better in plots
        n = -n
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def _xyz(v: Sequence[float]) -> dict[str, float]:
    return {"x": v[0], "y": v[1], "z": v[2]}


def _xyzw(q: Sequence[float]) -> dict[str, float]:
    return {"x": q[1], "y": q[2], "z": q[3], "w": q[0]}


def truth_to_tf(truth: Mapping[str, Any]) -> dict[str, Any]:
    """``/tf`` payload (foxglove.FrameTransform without timestamp) from a ``/sim/truth`` payload."""
    return {"parent_frame_id": WORLD_FRAME, "child_frame_id": BODY_FRAME,
            "translation": _xyz(ned_to_enu(truth["p_N_m"])), "rotation": _xyzw(q_NB_to_q_EF(truth["q_NB"]))}


def truth_to_pose(truth: Mapping[str, Any]) -> dict[str, Any]:
    """``/sim/pose`` payload (foxglove.PoseInFrame without timestamp) from a ``/sim/truth`` payload."""
    return {"frame_id": WORLD_FRAME,
            "pose": {"position": _xyz(ned_to_enu(truth["p_N_m"])), "orientation": _xyzw(q_NB_to_q_EF(truth["q_NB"]))}}
