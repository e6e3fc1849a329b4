"""ESC faults: an ESC refuses to arm, desyncs sporadically, or its output is stuck.

They use the ESC model's fault hooks ``Esc.set_refuse_arm / set_desync / set_stuck``,
combined per ESC by composers.EscComposer; each fault kind says which with its
``effect`` (composers.EscEffect).
"""

from __future__ import annotations

from typing import Any, ClassVar, TypeVar

from pydantic import Field

from hil.faults.base import Fault, FaultParams, Layer
from hil.faults.composers import EscEffect

ESC_HELP = "ESC index 0..3 (Maestro channel i, drives rotor i)"


class EscParams(FaultParams):
    esc: int = Field(ge=0, le=3, description=ESC_HELP)


EP = TypeVar("EP", bound=EscParams)


class _EscFault(Fault[EP]):
    """Base of the ESC faults: a composers.EscContributor of one ``effect``."""

    layer = Layer.DEVICE
    effect: ClassVar[EscEffect]

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"esc {params.esc}"

    @property
    def esc(self) -> int:
        return int(self.params.esc)

    @property
    def desync_rate_hz(self) -> float:
        """Desyncs per second (read for DESYNC only)."""
        return 0.0

    @property
    def stuck_throttle(self) -> float | None:
        """The stuck throttle 0..1, None = as at t_s (read for STUCK only)."""
        return None

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.escs.add(self, t_ns)
        return self.params.model_dump()

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.escs.remove(self, t_ns)
        return {"esc": self.esc, "armed": self.env.devices.escs[self.esc].armed}


class EscRefuseArm(_EscFault[EscParams]):
    """An ESC does not arm (failed calibration, wrong throttle range): the motor stays off
    while the fault lasts, and an ESC that armed before is unaffected."""

    kind = "esc.refuse_arm"
    Params = EscParams
    effect = EscEffect.REFUSE_ARM


class DesyncParams(EscParams):
    rate_hz: float = Field(default=2.0, gt=0.0, le=100.0, description="mean rate of desyncs (Poisson), 1/s")


class EscDesync(_EscFault[DesyncParams]):
    """Sporadic desyncs: thrust drops to zero for the ESC's desync_duration_s at random
    times (seeded by the ESC's generator)."""

    kind = "esc.desync"
    Params = DesyncParams
    effect = EscEffect.DESYNC

    @property
    def desync_rate_hz(self) -> float:
        return float(self.params.rate_hz)


class EscStuckParams(EscParams):
    throttle: float | None = Field(default=None, ge=0.0, le=1.0, description="stuck throttle 0..1; omitted: its value at t_s")


class EscStuck(_EscFault[EscStuckParams]):
    """An ESC's output is stuck (ignores its input)."""

    kind = "esc.stuck"
    Params = EscStuckParams
    effect = EscEffect.STUCK

    @property
    def stuck_throttle(self) -> float | None:
        return self.params.throttle


FAULTS: tuple[type[Fault[Any]], ...] = (EscRefuseArm, EscDesync, EscStuck)
