"""Telemetry radio link faults: dropout and packet loss.

They add a loss probability to the radio link (``RadioLink.set_loss_probability``), combined
with the rig's own loss and each other by composers.LinkLossComposer.
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import Field

from hil.faults.base import Fault, FaultParams, Layer, NoParams


LP = TypeVar("LP", bound=FaultParams)


class _LinkLoss(Fault[LP]):
    """Adds a loss probability to the radio link (composers.LinkLossComposer)."""

    layer = Layer.LINK

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "telemetry link"

    @property
    def loss_probability(self) -> float:
        raise NotImplementedError

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.link_loss.add(self, t_ns)
        return {"loss_probability": self.env.link_loss.combined()}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.link_loss.remove(self, t_ns)
        return {"loss_probability": self.env.link_loss.combined()}


class TelemetryDropout(_LinkLoss[NoParams]):
    """The radio link drops out (out of range): every transmission attempt is lost."""

    kind = "telemetry.dropout"
    Params = NoParams

    @property
    def loss_probability(self) -> float:
        return 1.0


class LossParams(FaultParams):
    loss_probability: float = Field(gt=0.0, lt=1.0, description="probability that one transmission attempt is lost")


class TelemetryLoss(_LinkLoss[LossParams]):
    """Packet loss on the radio link (interference): each attempt is lost with this probability
    (acknowledged packets are retried by the MAC as usual)."""

    kind = "telemetry.loss"
    Params = LossParams

    @property
    def loss_probability(self) -> float:
        return float(self.params.loss_probability)


FAULTS: tuple[type[Fault[Any]], ...] = (TelemetryDropout, TelemetryLoss)
