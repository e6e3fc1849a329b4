"""What the faults of one run act on, and how overlapping faults combine.

Several faults may act on the same thing at once (a baro bias during a baro noise
increase, two thrust losses on one rotor). Each device hook takes the *combined* setting,
so every shared target has a composer: faults add and remove themselves, and the composer
pushes the combination to the device whenever it changes:

* biases and offsets add, scale and noise factors multiply, "frozen"/"saturate" are ORed;
* thrust factors of one rotor multiply, battery series resistances add;
* loss probabilities combine as independent losses: 1 - prod(1 - p), the rig's own
  ``loss_probability`` included;
* the latest stuck value wins.

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

from emulators.analog.frontend import AccelFault, BaroFault

if TYPE_CHECKING:
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


class _Composer:
    """Holds the active contributors of one target; ``push`` applies their combination."""

    def __init__(self) -> None:
        self.items: list[Any] = []

    def add(self, item: Any, t_ns: int) -> None:
        self.items.append(item)
        self.push(t_ns)

    def remove(self, item: Any, t_ns: int) -> None:
        self.items.remove(item)
        self.push(t_ns)

    def push(self, t_ns: int) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


class BaroComposer(_Composer):
    """Contributors provide ``baro_terms(t_ns) -> BaroFault``."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        bias, scale, noise, frozen = 0.0, 1.0, 1.0, False
        for item in self.items:
            terms: BaroFault = item.baro_terms(t_ns)
            bias += terms.bias_Pa
            scale *= terms.scale
            noise *= terms.noise_factor
            frozen = frozen or terms.frozen
        fe = self._devices.analog
        combined = BaroFault(bias, scale, noise, frozen)
        if combined != fe.baro_fault:
            fe.set_baro_fault(bias_Pa=bias, scale=scale, noise_factor=noise, frozen=frozen)


class AccelComposer(_Composer):
    """Contributors provide ``accel_terms(t_ns) -> AccelFault`` (body axes)."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        bias = [0.0, 0.0, 0.0]
        scale, noise, frozen, saturate = 1.0, 1.0, False, False
        for item in self.items:
            terms: AccelFault = item.accel_terms(t_ns)
            for i in range(3):
                bias[i] += terms.bias_mps2[i]
            scale *= terms.scale
            noise *= terms.noise_factor
            frozen = frozen or terms.frozen
            saturate = saturate or terms.saturate
        fe = self._devices.analog
        b: Vec3 = (bias[0], bias[1], bias[2])
        if AccelFault(b, scale, noise, frozen, saturate) != fe.accel_fault:
            fe.set_accel_fault(bias_mps2=b, scale=scale, noise_factor=noise, frozen=frozen, saturate=saturate)


class RotorComposer(_Composer):
    """Contributors have ``rotor`` (0..3) and ``thrust_factor``; factors of a rotor multiply."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        self._pushed = [1.0, 1.0, 1.0, 1.0]

    def factors(self) -> list[float]:
        out = [1.0, 1.0, 1.0, 1.0]
        for item in self.items:
            out[item.rotor] *= item.thrust_factor
        return out

    def push(self, t_ns: int) -> None:
        for i, f in enumerate(self.factors()):
            if f != self._pushed[i]:
                self._devices.plant.set_rotor_thrust_factor(i, f)
                self._pushed[i] = f


class BatteryComposer(_Composer):
    """Contributors have ``extra_ohm``; series resistances add."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        self._devices.plant.set_battery_sag(sum(item.extra_ohm for item in self.items))


class LinkLossComposer(_Composer):
    """Contributors have ``loss_probability``; losses are independent."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        self.base = float(devices.rig.telemetry.link.loss_probability)

    def combined(self) -> float:
        keep = 1.0 - self.base
        for item in self.items:
            keep *= 1.0 - item.loss_probability
        return 1.0 - keep

    def push(self, t_ns: int) -> None:
        self._devices.link.set_loss_probability(self.combined())


class VrefComposer(_Composer):
    """Contributors provide ``vref_offset_V(t_ns)``; offsets add to the nominal reference."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        self.nominal_V: float | None = None

    def push(self, t_ns: int) -> None:
        mcp = self._devices.mcp
        if self.nominal_V is None:
            self.nominal_V = mcp.vref_V
        mcp.vref_V = self.nominal_V + sum(item.vref_offset_V(t_ns) for item in self.items)
        if not self.items:
            self.nominal_V = None


class AdcChannelComposer(_Composer):
    """Contributors have ``channel`` and either ``stuck_V`` (latest wins) or ``open`` = True."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        self._stuck: list[float | None] = [None] * 4
        self._open = [False] * 4

    def push(self, t_ns: int) -> None:
        fe = self._devices.analog
        stuck: list[float | None] = [None] * 4
        opened = [False] * 4
        for item in self.items:
            if getattr(item, "open", False):
                opened[item.channel] = True
            else:
                stuck[item.channel] = item.stuck_V
        for ch in range(4):
            if stuck[ch] != self._stuck[ch]:
                fe.set_channel_stuck(ch, stuck[ch])
            if opened[ch] != self._open[ch]:
                fe.set_channel_open(ch, opened[ch])  # (re)starts the drift from the cut
        self._stuck, self._open = stuck, opened


class EscComposer(_Composer):
    """Contributors have ``esc`` and one of ``refuse_arm`` / ``desync_rate_hz`` / ``stuck_throttle``."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        #: per ESC: (refuse, desync rate, the stuck contributor or None)
        self._pushed: list[tuple[bool, float, Any]] = [(False, 0.0, None)] * len(devices.escs)

    def push(self, t_ns: int) -> None:
        for i, esc in enumerate(self._devices.escs):
            mine = [item for item in self.items if item.esc == i]
            refuse = any(getattr(item, "refuse_arm", False) for item in mine)
            rate = sum(getattr(item, "desync_rate_hz", 0.0) for item in mine)
            stuck = [item for item in mine if hasattr(item, "stuck_throttle")]
            last = stuck[-1] if stuck else None
            old_refuse, old_rate, old_stuck = self._pushed[i]
            if refuse != old_refuse:
                esc.set_refuse_arm(refuse)
            if rate != old_rate:
                esc.set_desync(rate)
            if last is not old_stuck:
                if last is None:
                    esc.set_stuck(False)
                else:  # None: frozen at the throttle it has now
                    esc.set_stuck(True, last.stuck_throttle)
            self._pushed[i] = (refuse, rate, last)


class ImuSilence(_Composer):
    """The XSENS stops streaming while any contributor is active."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        self._devices.imu.set_silenced(bool(self.items))


@dataclass
class LossWindow:
    """PPM signal absent for frames starting in ``[start_ns, end_ns)`` (None: open)."""

    start_ns: int
    end_ns: int | None


class _GatedScript:
    """The stick script with extra signal-loss windows (everything else delegated)."""

    def __init__(self, inner: Any, windows: list[LossWindow]) -> None:
        self.inner = inner
        self.windows = windows

    def signal_present(self, t_ns: int) -> bool:
        for w in self.windows:
            if w.start_ns <= t_ns and (w.end_ns is None or t_ns < w.end_ns):
                return False
        return bool(self.inner.signal_present(t_ns))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


class RcLossGate:
    """Wraps ``devices.ppm.script`` while RC signal-loss faults have windows."""

    def __init__(self, devices: DeviceSet) -> None:
        self._devices = devices
        self.windows: list[LossWindow] = []
        self._inner: Any = None
        self._last_t: int | None = None

    def open(self, start_ns: int, end_ns: int | None) -> LossWindow:
        w = LossWindow(start_ns, end_ns)
        self.windows.append(w)
        if self._inner is None:
            ppm = self._devices.ppm
            self._inner = ppm.script
            ppm.script = _GatedScript(self._inner, self.windows)  # type: ignore[assignment] # duck-typed
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

