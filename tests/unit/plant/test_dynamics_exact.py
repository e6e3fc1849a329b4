"""The inlined derivative and the unrolled RK4 step (hil/plant/dynamics.py) give the same
floats, bit for bit, as the reference written one helper per term
(dynamics_reference.py): a recorded flight re-flown with either must verify IDENTICAL
(docs/replay-and-campaigns.md), so "close" is not enough."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.plant import dynamics
from hil.plant.params import PlantParams
from hil.plant.plant import Plant

from . import dynamics_reference as ref

_f = st.floats(-60.0, 60.0, allow_nan=False, allow_infinity=False)
_speed = st.floats(0.0, 1500.0, allow_nan=False, allow_infinity=False)


def _constants(rotor_aero: bool) -> dynamics.DynamicsConstants:
    plant = Plant(PlantParams(), np.random.default_rng(0))
    k = plant._k
    if not rotor_aero:
        from dataclasses import replace

        k = replace(k, rotor_drag=0.0, rotor_drag_z=0.0, flapping=0.0)
    return k


_K = {True: _constants(True), False: _constants(False)}


@st.composite
def _state_inputs(draw: st.DrawFn) -> tuple[list[float], tuple[float, ...]]:
    x = [draw(_f) for _ in range(6)]
    q = [draw(st.floats(-1.0, 1.0)) for _ in range(4)]
    n = math.sqrt(sum(v * v for v in q)) or 1.0
    x += [v / n for v in q] + [draw(_f) for _ in range(3)] + [draw(_speed) for _ in range(4)]
    x[2] = draw(st.one_of(st.floats(-1.0, 0.5), _f))  # near the ground too (ground effect)
    u = tuple([draw(_speed) for _ in range(4)] + [draw(_f) for _ in range(3)]
              + [draw(st.floats(0.5, 1.2))] + [draw(st.floats(-3.0, 3.0)) for _ in range(12)])
    return x, u


@settings(max_examples=400, deadline=None)
@given(_state_inputs(), st.booleans(), st.sampled_from([1e-4, 0.00125, 0.0025]))
def test_derivative_and_step_equal_the_reference_bit_for_bit(xu: tuple[list[float], tuple[float, ...]],
                                                             rotor_aero: bool, h_s: float) -> None:
    x, u = xu
    k = _K[rotor_aero]
    f_new, f_ref = dynamics.make_derivative(k), ref.make_derivative(k)
    assert f_new(x, u) == f_ref(x, u)
    assert _outcome(dynamics.rk4_step, f_new, x, u, h_s) == _outcome(ref.rk4_step, f_ref, x, u, h_s)


def _outcome(step, f, x, u, h_s) -> object:  # type: ignore[no-untyped-def]
    """The step's result, or the exception's type (a quaternion driven through zero)."""
    try:
        return step(f, list(x), u, h_s)
    except ZeroDivisionError as e:
        return type(e)


def test_a_change_in_one_term_is_seen() -> None:
    """The comparison above can fail: a derivative that differs in one term by a part in 1e12."""
    k = _K[True]
    x = [0.0, 0.0, -5.0, 1.0, -0.5, 0.2, 1.0, 0.0, 0.0, 0.0, 0.1, -0.2, 0.05, 600.0, 610.0, 590.0, 605.0]
    u = (620.0, 600.0, 600.0, 610.0, 1.0, 0.5, 0.0, 1.0, *([0.1] * 12))
    f_new, f_ref = dynamics.make_derivative(k), ref.make_derivative(k)

    def nudged(xs: list[float] | tuple[float, ...], us: tuple[float, ...]) -> tuple[float, ...]:
        d = list(f_new(xs, us))
        d[11] *= 1.0 + 1e-12
        return tuple(d)

    assert nudged(x, u) != f_ref(x, u)
    assert dynamics.rk4_step(nudged, list(x), u, 0.00125) != ref.rk4_step(f_ref, list(x), u, 0.00125)
