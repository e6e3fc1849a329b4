"""Property and stateful tests: whatever the inputs and faults, the plant stays physical."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from hil.plant.atmosphere import ISA_EXPONENT, ISA_LAPSE_K_PER_M, ISA_T0_K, isa_pressure_Pa
from hil.plant.quat import from_euler
from hil.plant.rotors import throttle_from_pulse_us

from .support import TICK_NS, make_plant

unit = st.floats(min_value=0.0, max_value=1.0)
wild = st.floats(allow_nan=True, allow_infinity=True)


@settings(deadline=None, max_examples=200)
@given(st.floats(min_value=500.0, max_value=2500.0), st.floats(min_value=500.0, max_value=2500.0))
def test_throttle_from_pulse_is_monotonic_and_bounded(a: float, b: float) -> None:
    lo, hi = sorted((a, b))
    assert 0.0 <= throttle_from_pulse_us(lo) <= throttle_from_pulse_us(hi) <= 1.0


@settings(deadline=None, max_examples=200)
@given(st.floats(min_value=-400.0, max_value=10_000.0), st.floats(min_value=90_000.0, max_value=110_000.0))
def test_isa_inverts_to_the_altimeter_formula(h_m: float, qnh_Pa: float) -> None:
    p = isa_pressure_Pa(h_m, qnh_Pa)
    h_back = ISA_T0_K / ISA_LAPSE_K_PER_M * (1.0 - (p / qnh_Pa) ** (1.0 / ISA_EXPONENT))
    assert math.isclose(h_back, h_m, abs_tol=1e-6)
    assert isa_pressure_Pa(h_m + 1.0, qnh_Pa) < p


class PlantMachine(RuleBasedStateMachine):
    """Random throttles, durations, placements and faults; physical invariants always hold."""

    @initialize(seed=st.integers(min_value=0, max_value=2**32 - 1))
    def start(self, seed: int) -> None:
        from hil.plant import WindParams

        self.plant = make_plant(seed=seed, wind=WindParams(turbulence_sigma_N_mps=(1.0, 1.0, 0.5)))
        self.last_t = self.plant.t_ns
        self.last_soc = self.plant.state.battery_soc

    @rule(thr=st.tuples(wild, wild, wild, wild), n=st.integers(min_value=1, max_value=40))
    def step(self, thr: tuple[float, float, float, float], n: int) -> None:
        self.plant.step(self.plant.t_ns + n * TICK_NS, thr)

    @rule(thr=st.tuples(unit, unit, unit, unit), ns=st.integers(min_value=1, max_value=20 * TICK_NS))
    def step_odd(self, thr: tuple[float, float, float, float], ns: int) -> None:
        self.plant.step(self.plant.t_ns + ns, thr)

    @rule(d=st.floats(min_value=0.5, max_value=1.0), n=st.integers(min_value=20, max_value=200))
    def climb(self, d: float, n: int) -> None:
        self.plant.step(self.plant.t_ns + n * TICK_NS, (d, d, d, d))

    @rule(
        h=st.floats(min_value=0.0, max_value=30.0),
        vz=st.floats(min_value=-5.0, max_value=10.0),
        att=st.tuples(*[st.floats(min_value=-3.1, max_value=3.1)] * 3),
        w=st.tuples(*[st.floats(min_value=-10.0, max_value=10.0)] * 3),
    )
    def place(self, h: float, vz: float, att: tuple[float, float, float], w: tuple[float, float, float]) -> None:
        self.plant.set_kinematic_state((0.0, 0.0, -h), v_N_mps=(1.0, 0.0, vz), q_NB=from_euler(*att), omega_B_radps=w)

    @rule(m=st.floats(min_value=0.0, max_value=0.8), r=st.tuples(*[st.floats(min_value=-0.15, max_value=0.15)] * 3))
    def payload(self, m: float, r: tuple[float, float, float]) -> None:
        self.plant.set_payload(m, r)

    @rule(i=st.integers(min_value=0, max_value=3), f=st.floats(min_value=0.0, max_value=1.0))
    def thrust_factor(self, i: int, f: float) -> None:
        self.plant.set_rotor_thrust_factor(i, f)

    @rule(ohm=st.floats(min_value=0.0, max_value=0.5))
    def sag(self, ohm: float) -> None:
        self.plant.set_battery_sag(ohm)

    @rule(w=st.tuples(*[st.floats(min_value=-15.0, max_value=15.0)] * 3), ms=st.integers(min_value=1, max_value=2000))
    def gust(self, w: tuple[float, float, float], ms: int) -> None:
        self.plant.add_gust(w, self.plant.t_ns, ms * 1_000_000)

    @rule()
    def reset(self) -> None:
        self.plant.reset_on_ground()

    @invariant()
    def physical(self) -> None:
        s = self.plant.state
        truth = self.plant.sensors()
        values = s.p_N_m + s.v_N_mps + s.q_NB + s.omega_B_radps + s.rotor_omega_radps + s.thrust_N
        values += truth.f_S_mps2 + truth.f_acc_B_mps2 + (truth.p_static_Pa, s.battery_V)
        assert all(math.isfinite(v) for v in values)
        assert s.h_m >= 0.0
        assert abs(math.fsum(c * c for c in s.q_NB) - 1.0) < 1e-12
        assert min(s.rotor_omega_radps) >= 0.0 and min(s.thrust_N) >= 0.0
        if s.on_ground:
            assert s.h_m == 0.0 and s.v_N_mps == (0.0, 0.0, 0.0) and s.omega_B_radps == (0.0, 0.0, 0.0)
            assert abs(s.euler_rpy_rad[0]) < 1e-9 and abs(s.euler_rpy_rad[1]) < 1e-9
        assert s.t_ns >= self.last_t and 0.0 <= s.battery_soc <= self.last_soc
        self.last_t, self.last_soc = s.t_ns, s.battery_soc


PlantMachine.TestCase.settings = settings(deadline=None, max_examples=25, stateful_step_count=15)
TestPlantMachine = PlantMachine.TestCase
