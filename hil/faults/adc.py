"""ADC faults: an MCP3204 input stuck or open, its reference drifting, its DOUT line pulled up.

They use the analog front-end's input hooks (``set_channel_stuck``, ``set_channel_open``,
combined by composers.AdcChannelComposer) and ``vref_V`` of the run's MCP3204 (the one
behind the Bus Pirate on the ``adc`` port, composers.VrefComposer).
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, NoParams, Refused
from hil.faults.composers import AdcChannelEffect
from hil.faults.imu import refuse_if_zero


class ChannelStuckParams(FaultParams):
    channel: int = Field(ge=0, le=3, description="MCP3204 input CH0..CH3")
    stuck_V: float = Field(ge=0.0, description="the input's voltage while stuck, V")


class AdcChannelStuck(Fault[ChannelStuckParams]):
    """An ADC input is stuck at a voltage (shorted line, dead amplifier)."""

    kind = "adc.channel_stuck"
    layer = Layer.SENSOR
    Params = ChannelStuckParams
    effect = AdcChannelEffect.STUCK

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        vdd = rig.adc.mcp3204.vdd_V
        if params.stuck_V > vdd:
            raise Refused("stuck_V", f"above the MCP3204's supply {vdd:g} V (the input cannot sit there)")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"adc CH{params.channel}"

    @property
    def channel(self) -> int:
        return int(self.params.channel)

    @property
    def stuck_V(self) -> float:
        return float(self.params.stuck_V)

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.adc.add(self, t_ns)
        return {"channel": self.channel, "stuck_V": self.stuck_V}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.adc.remove(self, t_ns)
        return {"channel": self.channel, "stuck_V": None}


class ChannelParams(FaultParams):
    channel: int = Field(ge=0, le=3, description="MCP3204 input CH0..CH3")


class AdcChannelOpen(Fault[ChannelParams]):
    """An ADC input is disconnected (broken wire): it floats from its last voltage towards
    the rig's ``open_input_level_V`` with noise."""

    kind = "adc.channel_open"
    layer = Layer.SENSOR
    Params = ChannelParams
    effect = AdcChannelEffect.OPEN

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if rig.analog.channel_map[params.channel] == "none":
            raise Refused("channel", f"CH{params.channel} is not connected on this rig ([analog] channel_map)")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"adc CH{params.channel}"

    @property
    def channel(self) -> int:
        return int(self.params.channel)

    @property
    def stuck_V(self) -> float | None:
        """None: an open input is held at no voltage (composers.AdcChannelContributor)."""
        return None

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.adc.add(self, t_ns)
        return {"channel": self.channel, "open": True}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.adc.remove(self, t_ns)
        return {"channel": self.channel, "open": False}


class VrefParams(FaultParams):
    step_V: float = Field(default=0.0, ge=-5.0, le=5.0, description="reference change at t_s, V")
    drift_V_per_s: float = Field(default=0.0, ge=-1.0, le=1.0, description="reference change per second from t_s, V/s")


class AdcVrefDrift(Fault[VrefParams]):
    """The MCP3204's reference moves (a sagging 5 V rail): every code scales by Vref0/Vref."""

    kind = "adc.vref_drift"
    layer = Layer.SENSOR
    Params = VrefParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        refuse_if_zero("step_V", params.step_V, params.drift_V_per_s)

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "adc VREF"

    def vref_offset_V(self, t_ns: int) -> float:
        p = self.params
        return float(p.step_V + p.drift_V_per_s * max(0, t_ns - self.t_start_ns) / NS_PER_S)

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.vref.add(self, t_ns)
        return {"vref_V": self.env.devices.mcp.vref_V}

    def update(self, t_ns: int) -> None:
        self.env.vref.push(t_ns)

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.vref.remove(self, t_ns)
        return {"vref_V": self.env.devices.mcp.vref_V}


class AdcDoutPulledUp(Fault[NoParams]):
    """A pull-up on the MCP3204's DOUT line (another SPI device's on the shared MISO, a board
    resistor): the clocks before the null bit, DOUT still hi-Z, read 1 instead of 0."""

    kind = "adc.dout_pulled_up"
    layer = Layer.WIRE
    Params = NoParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "adc DOUT"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.mcp.dout_pulled_up = True
        return {"dout_pulled_up": True}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.mcp.dout_pulled_up = False
        return {"dout_pulled_up": False}


FAULTS: tuple[type[Fault[Any]], ...] = (AdcChannelStuck, AdcChannelOpen, AdcVrefDrift, AdcDoutPulledUp)
