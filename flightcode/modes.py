"""Flight modes: arming, take-off, landing and failsafe as one table over Enums.

Theory of operation. :class:`ModeMachine` is fed once per IMU sample (:meth:`update`, with
the sample's sensor time) and once per IMU read timeout (:meth:`imu_lost`). ``update`` turns
the inputs into at most one :class:`ModeEvent` and looks it up in :data:`TRANSITIONS`; an
event with no entry for the current mode is ignored. Every timer runs on sensor time (the
IMU's SampleTimeFine), never on the wall clock; the IMU-loss watchdog is the read timeout.

======================  ===========================================================
event                   condition (all ``*_s`` held continuously on sensor time)
======================  ===========================================================
BOOT_DONE               the barometer reference is fixed
ARM_GESTURE             RC valid, throttle <= 1050 us and yaw >= 1900 us for 1 s
DISARM_GESTURE          RC valid, throttle <= 1050 us and yaw <= 1100 us for 1 s
TAKEOFF                 altitude setpoint > takeoff threshold
LANDED                  ground contact (below) and |vz estimate| < ``landed_vz_mps``
                        (the descent has stalled) for ``landed_s``
IDLE_TIMEOUT            armed on the ground for ``auto_disarm_s``
RC_LOST                 no good RC frame for ``failsafe.rc_loss_s`` (judged by the loop)
IMU_LOST                the IMU read timed out (``failsafe.imu_timeout_s`` of wall clock)
IMU_BACK                a sample arrived again: disarmed, re-arm to fly
======================  ===========================================================

Ground contact (:attr:`ModeMachine.ground_contact`, judged every sample while the controllers
fly): a landing is being flown (setpoint <= take-off threshold), the altitude estimate is
below ``landed_alt_m`` (near the ground), the collective applied is below
``landed_collective_ratio`` x the hover collective and the measured vertical acceleration
(low-passed) is within ``landed_accel_mps2`` of zero: the vehicle does not accelerate
downwards on a thrust that could not hold it in the air.

Motors per mode (:data:`MOTORS`): minimum pulse (the ESCs' arming level) in BOOT, DISARMED
and FAILSAFE_IMU (no attitude to control without the IMU); idle pulse when ARMED on the ground; the controllers in FLYING and
FAILSAFE_RC (level, descend at ``failsafe.descend_mps``, then disarm on landing). The
failsafe latches: RC coming back does not return control before the vehicle is disarmed.

Why the touchdown test is about thrust and measured acceleration, not height: near the
ground the altitude estimate is only as good as a barometer in rotor wash (it reads low) and
an integrated accelerometer, a few decimetres either way, and a vehicle on its ground cushion
hovers with a small vertical speed too. A landing declared from height and speed alone cut
the motors 0.2-0.5 m up on the bench. Not accelerating downwards on 70 % of the hover
collective (49 % of the hover thrust; at most 74 % with the strongest ground effect) is only
possible on the ground: in the air the accelerometer would read at least 2.5 m/s^2 down at
once, with no integration in between. The loop flies landings as a descent that does not
stop at the estimated ground level (:mod:`flightcode.control.landing`), so on the ground the
altitude loop winds the collective down until the test holds; and while ground contact
holds it tells the altitude filter that the vehicle stands still.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, IntEnum, unique


@unique
class Mode(IntEnum):
    """Flight mode; the value is what telemetry sends."""

    BOOT = 0
    DISARMED = 1
    ARMED = 2
    FLYING = 3
    FAILSAFE_RC = 4
    FAILSAFE_IMU = 5


@unique
class ModeEvent(Enum):
    """Inputs of the transition table."""

    BOOT_DONE = "boot_done"
    ARM_GESTURE = "arm_gesture"
    DISARM_GESTURE = "disarm_gesture"
    TAKEOFF = "takeoff"
    LANDED = "landed"
    IDLE_TIMEOUT = "idle_timeout"
    RC_LOST = "rc_lost"
    IMU_LOST = "imu_lost"
    IMU_BACK = "imu_back"


@unique
class MotorPolicy(Enum):
    """What the ESCs get in a mode."""

    MINIMUM = "minimum"
    IDLE = "idle"
    CONTROL = "control"


E, M = ModeEvent, Mode
TRANSITIONS: dict[Mode, dict[ModeEvent, Mode]] = {
    M.BOOT: {E.BOOT_DONE: M.DISARMED},
    M.DISARMED: {E.ARM_GESTURE: M.ARMED, E.IMU_LOST: M.FAILSAFE_IMU},
    M.ARMED: {E.TAKEOFF: M.FLYING, E.DISARM_GESTURE: M.DISARMED, E.IDLE_TIMEOUT: M.DISARMED,
              E.RC_LOST: M.DISARMED, E.IMU_LOST: M.FAILSAFE_IMU},
    M.FLYING: {E.LANDED: M.ARMED, E.RC_LOST: M.FAILSAFE_RC, E.IMU_LOST: M.FAILSAFE_IMU},
    M.FAILSAFE_RC: {E.LANDED: M.DISARMED, E.IMU_LOST: M.FAILSAFE_IMU},
    M.FAILSAFE_IMU: {E.IMU_BACK: M.DISARMED},
}
MOTORS: dict[Mode, MotorPolicy] = {
    M.BOOT: MotorPolicy.MINIMUM,
    M.DISARMED: MotorPolicy.MINIMUM,
    M.ARMED: MotorPolicy.IDLE,
    M.FLYING: MotorPolicy.CONTROL,
    M.FAILSAFE_RC: MotorPolicy.CONTROL,
    M.FAILSAFE_IMU: MotorPolicy.MINIMUM,
}
#: Modes in which the vehicle stands on the ground (motors at minimum or idle): the altitude
#: estimator may assume it is at rest. Not FAILSAFE_IMU: that one can start in the air.
AT_REST: frozenset[Mode] = frozenset({M.BOOT, M.DISARMED, M.ARMED})
del E, M


@dataclass(frozen=True)
class ModesParams:
    """``[modes]``: gestures and landing detection (times on sensor time).

    Fields:
        gesture_throttle_max_us: throttle at or below this for either gesture, us.
        arm_yaw_min_us: yaw at or above this arms, us.
        disarm_yaw_max_us: yaw at or below this disarms, us.
        gesture_hold_s: how long a gesture must be held, s.
        landed_alt_m: a touchdown is only believed with the altitude estimate below this
            (near the take-off level, with the estimate's error near the ground), m.
        landed_vz_mps: |vertical speed estimate| below this counts as at rest, m/s.
        landed_collective_ratio: applied collective below this fraction of the hover
            collective counts as "could not fly" (thrust ~ collective^2).
        landed_accel_mps2: |measured vertical acceleration| (low-passed) below this counts
            as "not falling", m/s^2.
        landed_s: how long all must hold (with the setpoint at or below take-off), s.
        auto_disarm_s: armed on the ground this long disarms, s.
    """

    __pydantic_config__ = {"extra": "forbid"}

    gesture_throttle_max_us: float = 1050.0
    arm_yaw_min_us: float = 1900.0
    disarm_yaw_max_us: float = 1100.0
    gesture_hold_s: float = 1.0
    landed_alt_m: float = 1.0
    landed_vz_mps: float = 0.3
    landed_collective_ratio: float = 0.7
    landed_accel_mps2: float = 1.0
    landed_s: float = 1.0
    auto_disarm_s: float = 5.0


@dataclass(frozen=True)
class Transition:
    """A mode change, for the log."""

    t_ns: int
    old: Mode
    new: Mode
    event: ModeEvent


def _ns(t_s: float) -> int:
    return int(round(t_s * 1e9))


class _Hold:
    """True once a condition has held continuously for ``hold_ns`` of sensor time."""

    __slots__ = ("hold_ns", "since_ns")

    def __init__(self, hold_ns: int) -> None:
        self.hold_ns = hold_ns
        self.since_ns: int | None = None

    def update(self, condition: bool, t_ns: int) -> bool:
        if not condition:
            self.since_ns = None
            return False
        if self.since_ns is None:
            self.since_ns = t_ns
        return t_ns - self.since_ns >= self.hold_ns

    def reset(self) -> None:
        self.since_ns = None


class ModeMachine:
    """The mode state machine (see the module docstring).

    Args:
        params: gesture and landing thresholds.
        takeoff_alt_m: altitude setpoint above which ARMED becomes FLYING, m.
    """

    def __init__(self, params: ModesParams, takeoff_alt_m: float) -> None:
        self.params = params
        self.takeoff_alt_m = takeoff_alt_m
        self.mode = Mode.BOOT
        #: Every transition so far, oldest first (the loop logs and clears it).
        self.transitions: list[Transition] = []
        self._arm = _Hold(_ns(params.gesture_hold_s))
        self._disarm = _Hold(_ns(params.gesture_hold_s))
        self._landed = _Hold(_ns(params.landed_s))
        self._idle = _Hold(_ns(params.auto_disarm_s))
        self._t_ns = 0
        #: The last sample's ground-contact test (module docstring; False unless the controllers
        #: fly, and after a transition).
        self.ground_contact = False
        #: Sensor time since which the vehicle has been in modes at rest (:data:`AT_REST`)
        #: without a break, ns; None while it is not. Boot starts at rest at sensor time 0.
        self.resting_since_ns: int | None = 0

    @property
    def motors(self) -> MotorPolicy:
        return MOTORS[self.mode]

    @property
    def at_rest(self) -> bool:
        """True while the vehicle stands on the ground (:data:`AT_REST`)."""
        return self.mode in AT_REST

    @property
    def controllers_active(self) -> bool:
        """True when the attitude/altitude controllers drive the motors."""
        return MOTORS[self.mode] is MotorPolicy.CONTROL

    def _fire(self, event: ModeEvent, t_ns: int) -> bool:
        table = TRANSITIONS[self.mode]
        if event not in table:
            return False
        new = table[event]
        self.transitions.append(Transition(t_ns, self.mode, new, event))
        if new not in AT_REST:
            self.resting_since_ns = None
        elif self.mode not in AT_REST:
            self.resting_since_ns = t_ns
        self.mode = new
        self.ground_contact = False  # judged again in the new mode
        for hold in (self._arm, self._disarm, self._landed, self._idle):
            hold.reset()
        return True

    def imu_lost(self) -> Mode:
        """The IMU read timed out (watchdog); returns the new mode."""
        self._fire(ModeEvent.IMU_LOST, self._t_ns)
        return self.mode

    def update(self, t_ns: int, *, baro_ready: bool, rc_valid: bool, throttle_us: float, yaw_us: float,
               z_ref_m: float, z_hat_m: float, vz_hat_mps: float, collective: float, hover_collective: float,
               a_up_mps2: float) -> Mode:
        """One sample at sensor time ``t_ns``; returns the (possibly new) mode.

        ``throttle_us``/``yaw_us`` are the latest stick pulses (ignored unless ``rc_valid``);
        ``z_ref_m`` the altitude setpoint in force (sticks, or the landing descent);
        ``z_hat_m``/``vz_hat_mps`` the altitude estimate (z up); ``collective`` the collective
        throttle applied over the last sample (0 when the controllers do not drive the motors)
        and ``hover_collective`` the collective that holds the vehicle in the air (unit
        throttle, both); ``a_up_mps2`` the measured vertical acceleration, low-passed (m/s^2,
        up; from the IMU, not the estimate).
        """
        self._t_ns = t_ns
        p = self.params
        mode = self.mode
        self.ground_contact = (MOTORS[mode] is MotorPolicy.CONTROL and z_ref_m <= self.takeoff_alt_m
                               and z_hat_m < p.landed_alt_m and collective < p.landed_collective_ratio * hover_collective
                               and abs(a_up_mps2) < p.landed_accel_mps2)
        if mode is Mode.FAILSAFE_IMU:
            self._fire(ModeEvent.IMU_BACK, t_ns)
            return self.mode
        if mode is Mode.BOOT:
            if baro_ready:
                self._fire(ModeEvent.BOOT_DONE, t_ns)
            return self.mode
        if not rc_valid and self._fire(ModeEvent.RC_LOST, t_ns):
            return self.mode
        low = rc_valid and throttle_us <= p.gesture_throttle_max_us
        if self._arm.update(low and yaw_us >= p.arm_yaw_min_us, t_ns) and self._fire(ModeEvent.ARM_GESTURE, t_ns):
            return self.mode
        if self._disarm.update(low and yaw_us <= p.disarm_yaw_max_us, t_ns) and self._fire(
                ModeEvent.DISARM_GESTURE, t_ns):
            return self.mode
        if z_ref_m > self.takeoff_alt_m and self._fire(ModeEvent.TAKEOFF, t_ns):
            return self.mode
        on_ground = self.ground_contact and abs(vz_hat_mps) < p.landed_vz_mps
        if self._landed.update(on_ground, t_ns) and self._fire(ModeEvent.LANDED, t_ns):
            return self.mode
        if self._idle.update(self.mode is Mode.ARMED, t_ns):
            self._fire(ModeEvent.IDLE_TIMEOUT, t_ns)
        return self.mode
