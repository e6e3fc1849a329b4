"""NED/FRD truth -> ENU/FLU for Foxglove, checked against explicit rotation matrices."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.record.frames import BODY_FRAME, WORLD_FRAME, ned_to_enu, q_NB_to_q_EF, truth_to_pose, truth_to_tf

R_EN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # NED -> ENU axes
R_BF = np.diag([1.0, -1.0, -1.0])  # FLU -> FRD axes


def rot(q: tuple[float, ...] | list[float]) -> np.ndarray:
    """Rotation matrix of a unit (w, x, y, z) quaternion (active, Hamilton)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def q_yaw(yaw_rad: float) -> list[float]:
    return [math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)]


def test_level_nose_north_points_along_enu_y_and_up_is_up() -> None:
    R = rot(q_NB_to_q_EF([1.0, 0.0, 0.0, 0.0]))
    assert np.allclose(R @ [1, 0, 0], [0, 1, 0])  # forward -> north
    assert np.allclose(R @ [0, 0, 1], [0, 0, 1])  # FLU up -> ENU up
    assert np.allclose(R @ [0, 1, 0], [-1, 0, 0])  # left -> west


def test_nose_east_points_along_enu_x() -> None:
    R = rot(q_NB_to_q_EF(q_yaw(math.pi / 2)))  # NED yaw +90 deg = east
    assert np.allclose(R @ [1, 0, 0], [1, 0, 0])


def test_positions() -> None:
    assert ned_to_enu([1.0, 2.0, -3.0]) == (2.0, 1.0, 3.0)  # 1 m north, 2 m east, 3 m up


quat = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 4).filter(lambda q: sum(v * v for v in q) > 1e-3)


@settings(deadline=None, max_examples=200)
@given(quat)
def test_matches_the_matrix_composition(q: tuple[float, float, float, float]) -> None:
    n = math.sqrt(sum(v * v for v in q))
    q_NB = [v / n for v in q]
    q_EF = q_NB_to_q_EF(q_NB)
    assert q_EF[0] >= 0
    assert math.isclose(sum(v * v for v in q_EF), 1.0, rel_tol=1e-9)
    assert np.allclose(rot(q_EF), R_EN @ rot(q_NB) @ R_BF, atol=1e-9)


def test_foxglove_payloads() -> None:
    truth = {"p_N_m": [1.0, 2.0, -3.0], "q_NB": q_yaw(math.pi / 2)}
    tf = truth_to_tf(truth)
    assert (tf["parent_frame_id"], tf["child_frame_id"]) == (WORLD_FRAME, BODY_FRAME)
    assert tf["translation"] == {"x": 2.0, "y": 1.0, "z": 3.0}
    r = tf["rotation"]
    assert np.allclose(rot([r["w"], r["x"], r["y"], r["z"]]), np.eye(3), atol=1e-12)  # east in ENU = identity
    pose = truth_to_pose(truth)
    assert pose["frame_id"] == WORLD_FRAME
    assert pose["pose"]["position"] == tf["translation"] and pose["pose"]["orientation"] == tf["rotation"]
