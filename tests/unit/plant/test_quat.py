"""Quaternion helpers: properties against numpy/independent constructions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.plant import quat

angle = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)
comp = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)
vec = st.tuples(comp, comp, comp)
unit_q = st.tuples(comp, comp, comp, comp).filter(lambda q: sum(c * c for c in q) > 1e-3).map(quat.normalized)
FAST = settings(deadline=None, max_examples=200)


def _rx(a: float) -> np.ndarray:
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def _ry(a: float) -> np.ndarray:
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def _rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


@FAST
@given(angle, st.floats(min_value=-1.5, max_value=1.5), angle)
def test_from_euler_is_zyx_rotation_matrix(roll: float, pitch: float, yaw: float) -> None:
    r = np.array(quat.to_matrix(quat.from_euler(roll, pitch, yaw)))
    np.testing.assert_allclose(r, _rz(yaw) @ _ry(pitch) @ _rx(roll), atol=1e-12)


@FAST
@given(angle, st.floats(min_value=-1.5, max_value=1.5), angle)
def test_euler_round_trip(roll: float, pitch: float, yaw: float) -> None:
    back = quat.to_euler(quat.from_euler(roll, pitch, yaw))
    for a, b in zip(back, (roll, pitch, yaw), strict=True):
        assert math.isclose(math.remainder(a - b, 2 * math.pi), 0.0, abs_tol=1e-9)


@FAST
@given(unit_q, unit_q, vec)
def test_product_composes_rotations(a: quat.Quat, b: quat.Quat, v: quat.Vec3) -> None:
    np.testing.assert_allclose(quat.rotate(quat.mul(a, b), v), quat.rotate(a, quat.rotate(b, v)), atol=1e-12)


@FAST
@given(unit_q, vec)
def test_rotate_inv_undoes_rotate_and_conj_inverts(q: quat.Quat, v: quat.Vec3) -> None:
    np.testing.assert_allclose(quat.rotate_inv(q, quat.rotate(q, v)), v, atol=1e-12)
    np.testing.assert_allclose(quat.rotate(quat.conj(q), v), quat.rotate_inv(q, v), atol=1e-12)
    r = np.array(quat.to_matrix(q))
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)


@FAST
@given(unit_q)
def test_yaw_only_keeps_heading_and_is_level(q: quat.Quat) -> None:
    level = quat.yaw_only(q)
    roll, pitch, yaw = quat.to_euler(level)
    assert abs(roll) < 1e-9 and abs(pitch) < 1e-9
    assert math.isclose(math.remainder(yaw - quat.to_euler(q)[2], 2 * math.pi), 0.0, abs_tol=1e-9)


@FAST
@given(vec, vec)
def test_cross_matches_numpy(a: quat.Vec3, b: quat.Vec3) -> None:
    np.testing.assert_allclose(quat.cross(a, b), np.cross(a, b), atol=1e-15)


def test_normalized_rejects_zero() -> None:
    with pytest.raises(ValueError, match="normalise"):
        quat.normalized((0.0, 0.0, 0.0, 0.0))
