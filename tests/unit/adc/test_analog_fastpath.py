"""The analog front-end's fast arithmetic against the straightforward code it replaced.

The per-tick path (``AnalogFrontEnd.update`` and the ``volts`` sampler) uses Python floats,
filter exponentials cached per step length and normals drawn in blocks. It must give the
very same bits as numpy element-wise arithmetic, a fresh ``two_stage``/``first_order`` per
step and single ``standard_normal()`` draws: ``ReferenceFrontEnd`` below is that code
(the previous implementation), run side by side on random inputs, faults and times.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import hypothesis.strategies as st
import numpy as np
from hypothesis import given, settings

from emulators.analog.adxl335 import Adxl335
from emulators.analog.conditioning import (
    NormalStream,
    TwoStageStep,
    first_order,
    two_stage,
)
from emulators.analog.frontend import AnalogFrontEnd
from emulators.analog.params import Adxl335Params, AnalogParams


class ReferenceFrontEnd(AnalogFrontEnd):
    """The previous update/static/noise code: numpy element-wise, exp per call, one draw per
    normal straight from the Generator."""

    def __init__(self, params: AnalogParams, rng: np.random.Generator) -> None:
        super().__init__(params, rng)
        single = NormalStream(rng, block=1)  # one Generator draw per normal
        self._normals = single
        for noise in self._noise:
            noise._rng = single

    def update(self, t_ns: int, p_Pa: float, f_B_mps2: Sequence[float], T_C: float) -> None:
        u = self._static(p_Pa, f_B_mps2, T_C)
        if self._t_ns is None:
            self._init_state(u)
            self._t_ns = t_ns
            return
        if t_ns < self._t_ns:
            self.counters["update_backwards"] += 1
            return
        dt_s = (t_ns - self._t_ns) * 1e-9
        for ch, sig in enumerate(self._sig):
            if sig is not None:
                self._x2[ch] = two_stage(
                    self._x1[sig], self._x2[ch], u[sig], self._tau_sensor[sig], self._tau_rc[ch], dt_s
                )
        for sig in range(4):
            self._x1[sig] = first_order(self._x1[sig], u[sig], self._tau_sensor[sig], dt_s)
        self._u = u
        self._t_ns = t_ns

    def _static(self, p_Pa: float, f_B_mps2: Sequence[float], T_C: float) -> list[float]:
        bf, af = self.baro_fault, self.accel_fault
        baro_V = self.baro.static_V(p_Pa * bf.scale + bf.bias_Pa, T_C)
        f = np.asarray(f_B_mps2, dtype=float) * af.scale + np.asarray(af.bias_mps2, dtype=float)
        acc_V = self.accel.static_V(f, T_C)
        if af.saturate:
            lo, hi = self.accel.swing_V
            mid = self.params.accel.supply_V / 2.0 + self.accel.zero_g_offset_V
            acc_V = np.where(acc_V >= mid, hi, lo)
        return [baro_V, *(float(v) for v in acc_V)]


FORCE = st.floats(-300.0, 300.0)
VEC = st.tuples(FORCE, FORCE, FORCE)
#: step lengths: the bench's tick (cached steps reused), zero, and arbitrary ones
DT = st.one_of(st.just(2_500_000), st.just(2_500_000), st.just(0), st.integers(1, 30_000_000))
OPS = st.one_of(
    st.tuples(st.just("update"), DT, st.floats(20_000.0, 130_000.0), VEC, st.floats(-50.0, 130.0)),
    st.tuples(st.just("update_back"), st.integers(1, 1000)),
    st.tuples(st.just("volts"), st.integers(-1, 4), st.integers(-1000, 3_000_000)),
    st.tuples(st.just("stuck"), st.integers(0, 3), st.one_of(st.none(), st.floats(0.0, 5.0))),
    st.tuples(st.just("open"), st.integers(0, 3), st.booleans()),
    st.tuples(st.just("baro"), st.floats(-500.0, 500.0), st.floats(0.9, 1.1), st.floats(0.0, 3.0), st.booleans()),
    st.tuples(st.just("accel"), VEC, st.floats(0.9, 1.1), st.floats(0.0, 3.0), st.booleans(), st.booleans()),
)
MOUNTS = [
    Adxl335Params(),
    Adxl335Params(mount_R_SB=((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))),
    Adxl335Params(filter_C_uF=(0.1, 0.01, 0.0049735919716217296), sensitivity_tolerance=0.0),
]


def apply(a: AnalogFrontEnd, op: tuple, clock: list[int]) -> object:
    kind = op[0]
    if kind == "update":
        clock[0] += op[1]
        a.update(clock[0], op[2], op[3], op[4])
        return None
    if kind == "update_back":
        a.update(clock[0] - op[1], 101_325.0, (0.0, 0.0, -9.8), 25.0)
        return None
    if kind == "volts":
        return a.volts(op[1], clock[0] + op[2])
    if kind == "stuck":
        a.set_channel_stuck(op[1], op[2])
    elif kind == "open":
        a.set_channel_open(op[1], op[2])
    elif kind == "baro":
        a.set_baro_fault(op[1], op[2], op[3], op[4])
    else:
        a.set_accel_fault(op[1], op[2], op[3], op[4], op[5])
    return None


@settings(deadline=None, max_examples=150)
@given(st.lists(OPS, max_size=40), st.integers(0, 2**16), st.sampled_from(MOUNTS),
       st.sampled_from([("baro", "accel_x", "accel_y", "accel_z"), ("baro", "none", "accel_z", "accel_x")]))
def test_front_end_matches_the_reference_bit_for_bit(
    ops: list[tuple], seed: int, accel: Adxl335Params, channel_map: tuple
) -> None:
    params = AnalogParams(accel=accel, channel_map=channel_map)
    fast = AnalogFrontEnd(params, np.random.default_rng(seed))
    ref = ReferenceFrontEnd(params, np.random.default_rng(seed))
    t_fast, t_ref = [0], [0]
    for op in ops:
        assert repr(apply(fast, op, t_fast)) == repr(apply(ref, op, t_ref)), op  # repr: exact, NaN-safe
        assert repr(fast.latched_V) == repr(ref.latched_V)
        assert list(fast.counters.items()) == list(ref.counters.items())
    for ch in range(4):  # and the noise streams are still in step
        assert repr(fast.volts(ch, t_fast[0] + 7)) == repr(ref.volts(ch, t_ref[0] + 7))


@settings(deadline=None, max_examples=300)
@given(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0), st.floats(-10.0, 10.0),
       st.sampled_from([0.0, 1e-4, 1.5915494309189535e-3, 4.551196133134061e-4, 0.05]),
       st.sampled_from([0.0, 1e-4, 1.5915494309189535e-3, 3.1830988618379067e-3]),
       st.sampled_from([0.0, 2.5e-3, 1e-6, 0.1]))
def test_two_stage_step_is_two_stage_bit_for_bit(x1: float, x2: float, u: float, tau1: float, tau2: float,
                                                 dt: float) -> None:
    step = TwoStageStep(tau1, tau2, dt)
    assert repr(step.apply(x1, x2, u)) == repr(two_stage(x1, x2, u, tau1, tau2, dt))
    assert repr(TwoStageStep(tau1, 0.0, dt).apply(x1, 0.0, u)) == repr(first_order(x1, u, tau1, dt))
    # the equal-time-constant limit
    assert repr(TwoStageStep(tau2, tau2, dt).apply(x1, x2, u)) == repr(two_stage(x1, x2, u, tau2, tau2, dt))


@settings(deadline=None, max_examples=200)
@given(VEC, st.floats(-60.0, 140.0), st.integers(0, 2**16), st.sampled_from(MOUNTS))
def test_accel_static_floats_are_the_numpy_values(f: tuple[float, float, float], T_C: float, seed: int,
                                                  params: Adxl335Params) -> None:
    a = Adxl335(params, np.random.default_rng(seed))
    assert a.static_V_floats(f, T_C) == a.static_V(np.array(f), T_C).tolist()
    assert a.static_V_floats(f, np.float64(T_C)) == a.static_V(np.array(f), np.float64(T_C)).tolist()
    assert all(type(v) is float for v in a.static_V_floats(f, np.float64(T_C)))
    nan = a.static_V_floats((math.nan, 0.0, 0.0), T_C)
    assert math.isnan(nan[0]) == bool(np.isnan(a.static_V(np.array([math.nan, 0.0, 0.0]), T_C)[0]))


@settings(deadline=None, max_examples=50)
@given(st.integers(0, 2**32), st.integers(1, 70), st.integers(0, 300))
def test_block_draws_are_the_single_draws(seed: int, block: int, n: int) -> None:
    """numpy's Generator.standard_normal(size=k) == k successive standard_normal() calls."""
    stream = NormalStream(np.random.default_rng(seed), block)
    single = np.random.default_rng(seed)
    assert [stream.standard_normal() for _ in range(n)] == [float(single.standard_normal()) for _ in range(n)]

