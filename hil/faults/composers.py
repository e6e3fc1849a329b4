"""How overlapping faults on one shared target combine: a composer per target.

Several faults may act on the same thing at once (a baro bias during a baro noise
increase, two thrust losses on one rotor). Each device hook takes the *combined* setting,
so every shared target has a composer: faults add and remove themselves, and the composer
pushes the combination to the device whenever it changes:

* biases and offsets add, scale and noise factors multiply, "frozen"/"saturate"/"port_blocked" are ORed;
* thrust factors of one rotor multiply, battery series resistances add;
* loss probabilities combine as independent losses: 1 - prod(1 - p), the rig's own
  ``loss_probability`` included;
* the latest stuck value wins.

What a composer reads of its contributors is a Protocol here (``BaroContributor``, ...);
the ADC channel and ESC faults say which of their target's settings they change with an
Enum (:class:`AdcChannelEffect`, :class:`EscEffect`).
"""

from __future__ import annotations

from enum import Enum, unique
from typing import TYPE_CHECKING, Generic, Protocol, TypeVar

from emulators.analog.frontend import AccelFault, BaroFault

if TYPE_CHECKING:
    from hil.flight.devices import DeviceSet
    from hil.plant.records import Vec3


# -- what the contributors provide --------------------------------------------------------------
class BaroContributor(Protocol):
    """A barometer fault: its terms at ``t_ns`` (Pa, factors, frozen)."""

    def baro_terms(self, t_ns: int) -> BaroFault: ...


class AccelContributor(Protocol):
    """An ADXL335 fault: its terms at ``t_ns`` (body axes FRD, m/s^2, factors, flags)."""

    def accel_terms(self, t_ns: int) -> AccelFault: ...


class RotorContributor(Protocol):
    """A rotor fault: which rotor (0..3) and the fraction of thrust it leaves."""

    @property
    def rotor(self) -> int: ...

    @property
    def thrust_factor(self) -> float: ...


class BatteryContributor(Protocol):
    """A battery fault: the series resistance it adds, ohm."""

    @property
    def extra_ohm(self) -> float: ...


class LinkLossContributor(Protocol):
    """A radio link fault: the probability that one transmission attempt is lost."""

    @property
    def loss_probability(self) -> float: ...


class VrefContributor(Protocol):
    """An MCP3204 reference fault: its offset from the nominal reference at ``t_ns``, V."""

    def vref_offset_V(self, t_ns: int) -> float: ...


@unique
class AdcChannelEffect(Enum):
    """What an ADC channel fault does to its MCP3204 input."""

    STUCK = "stuck"  #: held at ``stuck_V`` (the latest wins)
    OPEN = "open"  #: disconnected: floats towards the rig's open-input level


class AdcChannelContributor(Protocol):
    """An ADC channel fault: the input (CH0..CH3), its effect and, when STUCK, the voltage, V."""

    @property
    def channel(self) -> int: ...

    @property
    def effect(self) -> AdcChannelEffect: ...

    @property
    def stuck_V(self) -> float | None: ...


@unique
class EscEffect(Enum):
    """What an ESC fault does to its ESC."""

    REFUSE_ARM = "refuse_arm"  #: it does not arm while any is active
    DESYNC = "desync"  #: sporadic desyncs at ``desync_rate_hz`` (rates of one ESC add)
    STUCK = "stuck"  #: output stuck at ``stuck_throttle`` (the latest wins)


class EscContributor(Protocol):
    """An ESC fault: the ESC (0..3), its effect, and the setting of that effect
    (``desync_rate_hz`` 1/s for DESYNC, ``stuck_throttle`` 0..1 or None = as at t_s for STUCK)."""

    @property
    def esc(self) -> int: ...

    @property
    def effect(self) -> EscEffect: ...

    @property
    def desync_rate_hz(self) -> float: ...

    @property
    def stuck_throttle(self) -> float | None: ...


C = TypeVar("C")


# -- the composers ---------------------------------------------------------------------------------
class _Composer(Generic[C]):
    """Holds the active contributors of one target; ``push`` applies their combination."""

    def __init__(self) -> None:
        self.items: list[C] = []

    def add(self, item: C, t_ns: int) -> None:
        self.items.append(item)
        self.push(t_ns)

    def remove(self, item: C, t_ns: int) -> None:
        self.items.remove(item)
        self.push(t_ns)

    def push(self, t_ns: int) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


class BaroComposer(_Composer[BaroContributor]):
    """Contributors provide ``baro_terms(t_ns) -> BaroFault``."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        bias, scale, noise, frozen, blocked = 0.0, 1.0, 1.0, False, False
        for item in self.items:
            terms: BaroFault = item.baro_terms(t_ns)
            bias += terms.bias_Pa
            scale *= terms.scale
            noise *= terms.noise_factor
            frozen = frozen or terms.frozen
            blocked = blocked or terms.port_blocked
        fe = self._devices.analog
        combined = BaroFault(bias, scale, noise, frozen, blocked)
        if combined != fe.baro_fault:
            fe.set_baro_fault(bias_Pa=bias, scale=scale, noise_factor=noise, frozen=frozen, port_blocked=blocked)


class AccelComposer(_Composer[AccelContributor]):
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


class RotorComposer(_Composer[RotorContributor]):
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


class BatteryComposer(_Composer[BatteryContributor]):
    """Contributors have ``extra_ohm``; series resistances add."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        self._devices.plant.set_battery_sag(sum(item.extra_ohm for item in self.items))


class LinkLossComposer(_Composer[LinkLossContributor]):
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


class VrefComposer(_Composer[VrefContributor]):
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


class AdcChannelComposer(_Composer[AdcChannelContributor]):
    """Contributors have ``channel`` and an ``effect``: STUCK at ``stuck_V`` (latest wins) or OPEN."""

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
            if item.effect is AdcChannelEffect.OPEN:
                opened[item.channel] = True
            else:
                stuck[item.channel] = item.stuck_V
        for ch in range(4):
            if stuck[ch] != self._stuck[ch]:
                fe.set_channel_stuck(ch, stuck[ch])
            if opened[ch] != self._open[ch]:
                fe.set_channel_open(ch, opened[ch])  # (re)starts the drift from the cut
        self._stuck, self._open = stuck, opened


class EscComposer(_Composer[EscContributor]):
    """Contributors have ``esc`` and an ``effect``: REFUSE_ARM, DESYNC (``desync_rate_hz``) or
    STUCK (``stuck_throttle``)."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices
        #: per ESC: (refuse, desync rate, the stuck contributor or None)
        self._pushed: list[tuple[bool, float, EscContributor | None]] = [(False, 0.0, None)] * len(devices.escs)

    def push(self, t_ns: int) -> None:
        for i, esc in enumerate(self._devices.escs):
            mine = [item for item in self.items if item.esc == i]
            refuse = any(item.effect is EscEffect.REFUSE_ARM for item in mine)
            rate = sum(item.desync_rate_hz for item in mine if item.effect is EscEffect.DESYNC)
            stuck = [item for item in mine if item.effect is EscEffect.STUCK]
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


class ImuSilence(_Composer[object]):
    """The XSENS stops streaming while any contributor is active."""

    def __init__(self, devices: DeviceSet) -> None:
        super().__init__()
        self._devices = devices

    def push(self, t_ns: int) -> None:
        self._devices.imu.set_silenced(bool(self.items))
