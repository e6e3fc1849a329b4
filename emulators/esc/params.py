"""Parameters of one ESC (the paper's Pentium-18A, 50-500 Hz PWM input)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EscParams:
    """Behaviour of one ESC.

    ``min_us``/``max_us`` calibrated throttle range (1000-2000 us, BLHeli default);
    ``deadband_us`` widths <= min + deadband are zero throttle and count as "low" for
    arming; ``arm_time_s`` how long a low signal must last after power-up before the ESC
    arms; ``pwm_rate_hz`` the PWM frame rate the Maestro is configured for (50-490 Hz;
    the ESC sees a new width only at frame boundaries); ``signal_timeout_s`` no valid
    pulses for this long stops the motor and disarms (a re-arm is then needed);
    ``valid_min_us``/``valid_max_us`` widths outside count as no pulse;
    ``desync_duration_s`` length of one thrust drop when the desync fault is active.
    """

    __pydantic_config__ = {"extra": "forbid"}

    min_us: float = 1000.0
    max_us: float = 2000.0
    deadband_us: float = 30.0
    arm_time_s: float = 0.5
    pwm_rate_hz: float = 333.0
    signal_timeout_s: float = 0.25
    valid_min_us: float = 800.0
    valid_max_us: float = 2200.0
    desync_duration_s: float = 0.1

    def __post_init__(self) -> None:
        if not 50.0 <= self.pwm_rate_hz <= 490.0:
            raise ValueError("pwm_rate_hz must be 50..490")
        if self.max_us - self.min_us < 140:  # BLHeli: a smaller range is not accepted
            raise ValueError("max_us - min_us must be >= 140")
        if self.deadband_us < 0 or self.arm_time_s < 0 or self.signal_timeout_s <= 0:
            raise ValueError("deadband_us, arm_time_s >= 0 and signal_timeout_s > 0 required")
