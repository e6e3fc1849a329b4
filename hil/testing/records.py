"""What a bench hands its test: the errors its waits raise and the value records it returns
(plant truth, ESC command, injected fault). Times are sim time in seconds."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hil.faults import FaultHandle

S = 1_000_000_000  #: ns per s
#: host-clock runs: event-loop stalls longer than this are reported (the IMU watchdog is 0.1 s)
STALL_WARN_S = 0.05

#: a test's condition on the bench, judged at a tick: called with the ``Bench``
#: (hil.testing.bench, typed there by the waits), its truth value counts
Predicate = Callable[[Any], object]


class RunEnded(AssertionError):
    """The run ended (duration over, flight code exited, boot failed) before the awaited tick."""


class SimTimeout(AssertionError):
    """``until``: the predicate did not hold within ``timeout_s`` of sim time."""


class PredicateFailed(AssertionError):
    """``always``: the predicate was false at some tick."""


class HilBenchStallWarning(UserWarning):
    """The event loop was held (by the test's own code, usually) while the bench ran."""


@dataclass(frozen=True)
class Truth:
    """Plant truth at the last tick: NED world, FRD body, ZYX Euler angles in degrees."""

    t_s: float
    h_m: float  #: altitude above the field
    climb_mps: float  #: -v_N[2]
    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    p_N_m: tuple[float, float, float]
    v_N_mps: tuple[float, float, float]
    omega_B_degps: tuple[float, float, float]
    rotor_omega_radps: tuple[float, float, float, float]
    on_ground: bool
    battery_V: float
    state: Any = field(repr=False)  #: the full hil.plant.records.PlantState


@dataclass(frozen=True)
class EscCommand:
    """The flight code's last Maestro command: pulse widths of motors 0..3 (us), at ``t_s``."""

    t_s: float
    pulse_us: tuple[float, float, float, float]


@dataclass
class InjectedFault:
    """One ``bench.fault`` activation: sim times of its start and end (None while active)."""

    kind: str
    handle: FaultHandle
    t_start_s: float
    t_end_s: float | None = None
