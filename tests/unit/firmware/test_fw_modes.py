"""The firmware's mode machine (firmware/src/modes.c): the same table over the same enums as
flightcode/modes.py, and the same modes, ground contact and rest periods for any sequence of
inputs (a property test driving both machines side by side)."""

from __future__ import annotations

import ctypes as C

import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from flightcode.modes import AT_REST, MOTORS, TRANSITIONS, Mode, ModeEvent, ModeMachine, ModesParams, MotorPolicy
from tests.unit.firmware.fwcodecs import Codecs, ModesInputT, ModesParamsT, ModesT

TICK = 2_500_000
EVENTS = list(ModeEvent)  # the C enum's order: tested below by name


@pytest.fixture(scope="module")
def fw(tmp_path_factory: pytest.TempPathFactory) -> Codecs:
    return Codecs(tmp_path_factory.mktemp("codecs"))


def test_event_and_mode_names_in_the_same_order(fw: Codecs) -> None:
    assert [fw.dll.mode_event_name(i).decode() for i in range(len(EVENTS))] == [e.value for e in EVENTS]
    assert [fw.dll.mode_name(m.value).decode() for m in Mode] == [m.name.lower() for m in Mode]


def test_transition_table_is_the_python_table(fw: Codecs) -> None:
    table = fw.table()
    for mode in Mode:
        for i, event in enumerate(EVENTS):
            expected = TRANSITIONS[mode].get(event)
            assert table[mode.value][i] == (-1 if expected is None else expected.value), (mode, event)


def test_motor_policy_and_rest_are_the_python_ones(fw: Codecs) -> None:
    policies = {MotorPolicy.MINIMUM: 0, MotorPolicy.IDLE: 1, MotorPolicy.CONTROL: 2}
    assert fw.motors() == [policies[MOTORS[m]] for m in Mode]
    assert fw.at_rest() == [m in AT_REST for m in Mode]


def c_params(p: ModesParams, takeoff_alt_m: float) -> ModesParamsT:
    ns = lambda s: int(round(s * 1e9))  # noqa: E731
    return ModesParamsT(p.gesture_throttle_max_us, p.arm_yaw_min_us, p.disarm_yaw_max_us, ns(p.gesture_hold_s),
                        p.landed_alt_m, p.landed_vz_mps, p.landed_collective_ratio, p.landed_accel_mps2,
                        ns(p.landed_s), ns(p.auto_disarm_s), takeoff_alt_m)


# float32-exact values, so a comparison at a threshold goes the same way in both codes
stick = st.sampled_from([1000.0, 1040.0, 1050.0, 1100.0, 1500.0, 1900.0, 1950.0, 2000.0])
height = st.sampled_from([-0.5, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0, 5.0])
speed = st.sampled_from([-1.0, -0.3, -0.25, 0.0, 0.125, 0.3, 0.5])  # 0.3: landed_vz_mps
share = st.sampled_from([0.0, 0.25, 0.5, 0.625, 0.75])
accel = st.sampled_from([-3.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0])  # 1.0: landed_accel_mps2


class BothMachines(RuleBasedStateMachine):
    """The Python and the C mode machine fed the same samples and IMU losses."""

    @initialize()
    def start(self) -> None:
        self.fw = Codecs.shared
        params = ModesParams()
        self.py = ModeMachine(params, 0.5)
        self.c = ModesT()
        self.fw.dll.modes_init(C.byref(self.c), C.byref(c_params(params, 0.5)))
        self.t = 0

    @rule(ticks=st.integers(1, 600), baro=st.booleans(), rc=st.booleans(), thr=stick, yaw=stick, z_ref=height,
          z=height, vz=speed, collective=share, a_up=accel)
    def samples(self, ticks: int, baro: bool, rc: bool, thr: float, yaw: float, z_ref: float, z: float, vz: float,
                collective: float, a_up: float) -> None:
        for _ in range(ticks):
            self.t += TICK
            self.py.update(self.t, baro_ready=baro, rc_valid=rc, throttle_us=thr, yaw_us=yaw, z_ref_m=z_ref,
                           z_hat_m=z, vz_hat_mps=vz, collective=collective, hover_collective=0.75, a_up_mps2=a_up)
            inp = ModesInputT(baro, rc, thr, yaw, z_ref, z, vz, collective, 0.75, a_up)
            self.fw.dll.modes_update(C.byref(self.c), self.t, C.byref(inp))
            self.check_transitions()

    @rule()
    def arm_and_take_off(self) -> None:
        """The arm gesture held, then a take-off setpoint: the paths a random walk rarely finds."""
        self.samples(440, True, True, 1000.0, 2000.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self.samples(1, True, True, 1500.0, 1500.0, 2.0, 2.0, 0.0, 0.75, 0.0)

    @rule(ticks=st.integers(1, 600), z=height, vz=speed, collective=share, a_up=accel)
    def touch_down(self, ticks: int, z: float, vz: float, collective: float, a_up: float) -> None:
        """A landing being flown (setpoint at the ground) with the touchdown test's inputs at
        and around its thresholds."""
        self.samples(ticks, True, True, 1500.0, 1500.0, 0.0, z, vz, collective, a_up)

    @rule()
    def imu_lost(self) -> None:
        self.py.imu_lost()
        self.fw.dll.modes_imu_lost(C.byref(self.c))
        self.check_transitions()

    def check_transitions(self) -> None:
        py = [(tr.t_ns, tr.old.value, tr.new.value, tr.event.value) for tr in self.py.transitions]
        c = [(tr.t_ns, tr.old_mode, tr.new_mode, self.fw.dll.mode_event_name(tr.event).decode())
             for tr in self.c.transitions[:self.c.n_transitions]]
        assert c == py
        self.py.transitions.clear()
        self.c.n_transitions = 0

    @invariant()
    def same_state(self) -> None:
        assert self.c.mode == self.py.mode.value
        assert self.c.ground_contact == self.py.ground_contact
        since = self.py.resting_since_ns
        assert self.c.resting == (since is not None)
        if since is not None:
            assert self.c.resting_since_ns == since


def test_same_modes_as_the_python_machine(fw: Codecs) -> None:
    Codecs.shared = fw  # type: ignore[attr-defined]
    runner = BothMachines.TestCase
    runner.settings = settings(max_examples=40, stateful_step_count=30, deadline=None)
    runner().runTest()


def test_a_flight_through_every_mode(fw: Codecs) -> None:
    """Arm, take off, lose RC (failsafe), land, disarm, lose and regain the IMU: the C machine's
    modes one by one (a scripted flight; the property test compares with Python)."""
    m = ModesT()
    fw.dll.modes_init(C.byref(m), C.byref(c_params(ModesParams(), 0.5)))
    t = 0

    def run(seconds: float, **kw: float) -> int:
        nonlocal t
        inp = ModesInputT(True, kw.get("rc", True), kw.get("thr", 1000.0), kw.get("yaw", 1500.0), kw.get("z_ref", 0.0),
                          kw.get("z", 0.0), kw.get("vz", 0.0), kw.get("collective", 0.72), 0.72, kw.get("a_up", 0.0))
        for _ in range(int(seconds / 0.0025)):
            t += TICK
            fw.dll.modes_update(C.byref(m), t, C.byref(inp))
        return m.mode

    assert run(0.01) == Mode.DISARMED
    assert run(1.1, yaw=2000.0) == Mode.ARMED
    assert run(0.01, thr=1200.0, z_ref=2.0) == Mode.FLYING
    assert run(0.6, rc=False, z_ref=2.0, z=2.0) == Mode.FAILSAFE_RC
    assert run(0.5, rc=True, thr=1500.0, z_ref=0.0, z=0.1, collective=0.3) == Mode.FAILSAFE_RC  # latched
    assert run(1.1, rc=True, z_ref=-0.5, z=0.1, collective=0.3) == Mode.DISARMED  # landed
    assert fw.dll.modes_imu_lost(C.byref(m)) == Mode.FAILSAFE_IMU
    assert run(0.01) == Mode.DISARMED  # a sample again: imu_back


@pytest.mark.parametrize("z", [0.75, 1.0])
@pytest.mark.parametrize("vz", [0.25, 0.3, -0.3])
@pytest.mark.parametrize("a_up", [0.5, 1.0, -1.0])
def test_touchdown_thresholds_decide_as_python(fw: Codecs, z: float, vz: float, a_up: float) -> None:
    """A landing flown with the touchdown test's inputs exactly at its thresholds (height 1 m,
    speed 0.3 m/s, acceleration 1 m/s^2, all exact in float32): the same verdict, at the same
    sample, as the Python machine."""
    Codecs.shared = fw  # type: ignore[attr-defined]
    both = BothMachines()
    both.start()
    both.arm_and_take_off()
    assert both.c.mode == Mode.FLYING
    both.touch_down(500, z, vz, 0.25, a_up)
    both.same_state()
