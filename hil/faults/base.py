"""The shape of a fault: its parameters, how it is checked against a rig, applied and reverted.

Every fault kind is a :class:`Fault` subclass with

* ``kind`` ("wire.bit_flips"), ``layer`` (:class:`Layer`), ``timing`` (:class:`Timing`),
* ``Params``: a frozen pydantic model (extra keys forbidden, units in field names, a
  description per field) validated from the scenario's ``[[faults]]`` table,
* ``check(params, rig)``: refuses what this rig cannot do by raising :class:`Refused`
  naming the key and the reason (hil/faults/loader.py turns it into a ConfigError),
* ``apply(t_ns)`` / ``update(t_ns)`` (every tick while active) / ``revert(t_ns)``; apply
  and revert return a dict of what they changed, which goes into the event log.

A fault object lives for one activation and gets its own ``numpy.random.Generator``.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from enum import Enum, unique
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    import numpy as np

    from hil.faults.env import FaultEnv
    from hil.config.rig import Rig

NS_PER_S = 1_000_000_000

Vec3 = tuple[float, float, float]


@unique
class Layer(str, Enum):
    """Where a fault acts."""

    PLANT = "plant"  #: the vehicle and its environment
    SENSOR = "sensor"  #: what a sensor measures (bias, drift, noise, stuck, ...)
    WIRE = "wire"  #: the bytes on a port
    DEVICE = "device"  #: a device's behaviour (XSENS, RC receiver, ESC)
    LINK = "link"  #: the telemetry radio channel
    PROCESS = "process"  #: the flight code process


@unique
class Timing(str, Enum):
    """How a fault uses ``duration_s``."""

    SPAN = "span"  #: active from t_s for duration_s; omitted = until the end of the run
    BOUNDED = "bounded"  #: duration_s is required
    INSTANT = "instant"  #: one action at t_s; duration_s is not allowed


class FaultParams(BaseModel):
    """Base of every fault's parameter model (strict, immutable)."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class NoParams(FaultParams):
    """A fault without parameters."""


class Refused(Exception):
    """The rig cannot apply this fault: ``key`` is the offending parameter, ``reason`` why."""

    def __init__(self, key: str, reason: str) -> None:
        super().__init__(f"{key}: {reason}")
        self.key = key
        self.reason = reason


@dataclass(frozen=True)
class ScheduledFault:
    """One validated ``[[faults]]`` entry.

    ``t_s`` start (sim time, s); ``duration_s`` None = until the end (or instant);
    ``target`` what it acts on ("port imu tx", "rotor 2", ...); ``index`` the entry's
    position in the file and ``source`` the file, for messages.
    """

    kind: str
    t_s: float
    duration_s: float | None
    params: FaultParams
    target: str
    index: int | None = None
    source: str = ""

    @property
    def t_ns(self) -> int:
        return round(self.t_s * NS_PER_S)

    @property
    def end_ns(self) -> int | None:
        return None if self.duration_s is None else self.t_ns + round(self.duration_s * NS_PER_S)


P = TypeVar("P", bound=FaultParams)


class Fault(Generic[P]):
    """Base of the fault kinds (see the module docstring); ``P`` is the params model."""

    kind: ClassVar[str] = ""
    layer: ClassVar[Layer] = Layer.PLANT
    timing: ClassVar[Timing] = Timing.SPAN
    Params: ClassVar[type[FaultParams]] = NoParams

    def __init__(self, params: P, env: FaultEnv, rng: np.random.Generator) -> None:
        self.params: P = params
        self.env = env
        self.rng = rng
        #: Set by the schedule before ``apply``: when it started and when it is due to end.
        self.t_start_ns = 0
        self.end_ns: int | None = None

    # -- load time -----------------------------------------------------------------------------
    @classmethod
    def check(cls, params: Any, rig: Rig) -> None:
        """Raise :class:`Refused` if ``rig`` cannot apply this fault with ``params``."""

    @classmethod
    def target_of(cls, params: Any) -> str:
        """What the fault acts on, for listings and logs."""
        return cls.kind.partition(".")[0]

    # -- run time -------------------------------------------------------------------------------
    def apply(self, t_ns: int) -> dict[str, Any]:
        """Start acting at ``t_ns``; return what changed."""
        raise NotImplementedError

    def update(self, t_ns: int) -> None:
        """Called at the start of every tick while active (time-varying faults)."""

    def revert(self, t_ns: int) -> dict[str, Any]:
        """Stop acting at ``t_ns``; return what changed back."""
        return {}

    def exact_end(self, t_ns: int) -> int:
        """The scheduled end if it lies before ``t_ns`` (the tick that reverts), else ``t_ns``."""
        return t_ns if self.end_ns is None else min(self.end_ns, t_ns)

    # -- listing --------------------------------------------------------------------------------
    @classmethod
    def summary(cls) -> str:
        """First paragraph of the docstring."""
        doc = inspect.getdoc(cls) or ""
        return " ".join(doc.split("\n\n", 1)[0].split())

    @classmethod
    def describe(cls) -> dict[str, Any]:
        """Kind, layer, timing, description and parameters (name, type, unit, default, text)."""
        params = []
        for name, field in cls.Params.model_fields.items():
            params.append(
                {
                    "name": name,
                    "type": _type_name(field.annotation),
                    "unit": unit_of(name),
                    "default": None if field.is_required() else _plain(field.get_default(call_default_factory=True)),
                    "required": field.is_required(),
                    "description": field.description or "",
                }
            )
        return {
            "kind": cls.kind,
            "layer": cls.layer.value,
            "timing": cls.timing.value,
            "description": cls.summary(),
            "params": params,
        }


def _plain(value: Any) -> Any:
    """Enums as their values, so listings serialise to JSON."""
    return value.value if isinstance(value, Enum) else value


def _type_name(annotation: Any) -> str:
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        return " | ".join(repr(m.value) for m in annotation)
    text = getattr(annotation, "__name__", None) if not getattr(annotation, "__args__", None) else None
    return text or str(annotation).replace("typing.", "")


#: Unit suffixes of parameter names -> unit text.
_UNITS: tuple[tuple[str, str], ...] = (
    ("_radps_per_s", "rad/s^2"),
    ("_mps2_per_s", "m/s^2 per s"),
    ("_Pa_per_s", "Pa/s"),
    ("_V_per_s", "V/s"),
    ("_radps", "rad/s"),
    ("_mps2", "m/s^2"),
    ("_mps", "m/s"),
    ("_Pa", "Pa"),
    ("_kg", "kg"),
    ("_ohm", "ohm"),
    ("_bps", "bit/s"),
    ("_hz", "Hz"),
    ("_us", "us"),
    ("_s", "s"),
    ("_V", "V"),
    ("_m", "m"),
)


def unit_of(name: str) -> str:
    """The unit a parameter name carries ("" for dimensionless)."""
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""
