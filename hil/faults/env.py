"""What the faults of one run act on: the devices, the flight process, the composers of
shared targets (hil/faults/composers.py: how overlapping faults combine), the run's wire
filters and background tasks.

The IMU sensor faults transform the motion the bench hands to the XSENS model: while any
is active, ``devices.imu_motion`` holds their composition (removed again when the last one
ends), so the device's own error model (noise, bias random walk, range clipping with its
status flags) still applies on top.
RC signal loss wraps the PPM generator's stick script the same way (``signal_present``
false inside the loss windows).
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from hil.faults.composers import (
    AccelComposer,
    AdcChannelComposer,
    BaroComposer,
    BatteryComposer,
    EscComposer,
    ImuSilence,
    LinkLossComposer,
    RotorComposer,
    VrefComposer,
)

if TYPE_CHECKING:
    from emulators.rc.ppm import Sticks
    from hil.flight.devices import DeviceSet, WireFilter
    from hil.flight.process import FlightProcess

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Spawn = Callable[[Coroutine[Any, Any, None], str], None]
Note = Callable[[int, str, dict[str, Any]], None]


class MotionStage(Protocol):
    """An IMU sensor fault: ``stage`` orders the transforms (low first)."""

    stage: int

    def transform(self, t_ns: int, q_NS: Quat, w_S_radps: Vec3, f_S_mps2: Vec3) -> tuple[Quat, Vec3, Vec3]: ...


class ImuMotion:
    """Composes the active IMU sensor faults into ``devices.imu_motion``."""

    def __init__(self, devices: DeviceSet) -> None:
        self._devices = devices
        self._stages: list[MotionStage] = []

    def add(self, stage: MotionStage) -> None:
        self._stages.append(stage)
        self._stages.sort(key=lambda s: s.stage)  # stable: same stage keeps activation order
        self._devices.imu_motion = self._transform

    def remove(self, stage: MotionStage) -> None:
        self._stages.remove(stage)
        if not self._stages:
            self._devices.imu_motion = None

    @property
    def installed(self) -> bool:
        return self._devices.imu_motion is not None

    def _transform(self, t_ns: int, q_NS: Sequence[float], omega_S_radps: Sequence[float],
                   f_S_mps2: Sequence[float]) -> tuple[Quat, Vec3, Vec3]:
        q: Quat = (float(q_NS[0]), float(q_NS[1]), float(q_NS[2]), float(q_NS[3]))
        w: Vec3 = (float(omega_S_radps[0]), float(omega_S_radps[1]), float(omega_S_radps[2]))
        f: Vec3 = (float(f_S_mps2[0]), float(f_S_mps2[1]), float(f_S_mps2[2]))
        for s in self._stages:
            q, w, f = s.transform(t_ns, q, w, f)
        return q, w, f


@dataclass
class LossWindow:
    """PPM signal absent for frames starting in ``[start_ns, end_ns)`` (None: open)."""

    start_ns: int
    end_ns: int | None


class _GatedScript:
    """The stick script with extra signal-loss windows: a ``Sticks`` (emulators/rc/ppm.py),
    the one interface the PPM generator reads its script through."""

    def __init__(self, inner: Sticks, windows: list[LossWindow]) -> None:
        self.inner = inner
        self.windows = windows

    def signal_present(self, t_ns: int) -> bool:
        for w in self.windows:
            if w.start_ns <= t_ns and (w.end_ns is None or t_ns < w.end_ns):
                return False
        return bool(self.inner.signal_present(t_ns))

    def pulses_us(self, t_ns: int) -> tuple[int, ...]:
        return self.inner.pulses_us(t_ns)


class RcLossGate:
    """Wraps ``devices.ppm.script`` while RC signal-loss faults have windows."""

    def __init__(self, devices: DeviceSet) -> None:
        self._devices = devices
        self.windows: list[LossWindow] = []
        self._inner: Sticks | None = None
        self._last_t: int | None = None

    def open(self, start_ns: int, end_ns: int | None) -> LossWindow:
        w = LossWindow(start_ns, end_ns)
        self.windows.append(w)
        if self._inner is None:
            ppm = self._devices.ppm
            self._inner = ppm.script
            ppm.script = _GatedScript(self._inner, self.windows)
        return w

    def close(self, w: LossWindow, end_ns: int) -> None:
        w.end_ns = end_ns if w.end_ns is None else min(w.end_ns, end_ns)

    def sweep(self, t_ns: int) -> None:
        """Forget windows that ended before the last tick (its frames are generated); unwrap
        the script when none is left."""
        last = self._last_t
        self._last_t = t_ns
        if last is None:
            return
        self.windows[:] = [w for w in self.windows if w.end_ns is None or w.end_ns > last]
        if not self.windows and self._inner is not None:
            self._devices.ppm.script = self._inner
            self._inner = None


class FaultEnv:
    """The run's devices and flight process, the composers, wire filters and task spawning."""

    def __init__(self, devices: DeviceSet, *, flight: FlightProcess | None, spawn: Spawn, note: Note) -> None:
        self.devices = devices
        self.flight = flight
        self.spawn = spawn
        #: ``note(t_ns, name, detail)`` logs an event from a fault's background task.
        self.note = note
        self.imu_motion = ImuMotion(devices)
        self.imu_silence = ImuSilence(devices)
        self.baro = BaroComposer(devices)
        self.accel = AccelComposer(devices)
        self.rotors = RotorComposer(devices)
        self.battery = BatteryComposer(devices)
        self.link_loss = LinkLossComposer(devices)
        self.vref = VrefComposer(devices)
        self.adc = AdcChannelComposer(devices)
        self.escs = EscComposer(devices)
        self.rc_gate = RcLossGate(devices)
        self._filters: list[tuple[str, Any]] = []

    # -- wire filters ------------------------------------------------------------------------------
    def add_filter(self, port: str, filt: WireFilter) -> None:
        self.devices.wire_filters.setdefault(port, []).append(filt)
        self._filters.append((port, filt))

    def sweep(self, t_ns: int) -> None:
        """Start of a tick: take out finished wire filters, drop loss windows that are over."""
        self.sweep_filters()
        self.rc_gate.sweep(t_ns)

    def sweep_filters(self) -> None:
        """Take out wire filters that ended and hold nothing back."""
        for port, filt in list(self._filters):
            if filt.finished:
                self._filters.remove((port, filt))
                lst = self.devices.wire_filters.get(port, [])
                if filt in lst:
                    lst.remove(filt)
                if not lst:
                    self.devices.wire_filters.pop(port, None)

