"""XSENS device faults: the device itself stops streaming, resets or jumps its counter.

They use the XSENS model's fault hooks ``MtiDevice.set_silenced`` (through
composers.ImuSilence), ``power_cycle`` and ``jump_packet_counter``. What the sensor
measures (bias, drift, noise, ...) is hil/faults/imu.py.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from hil.faults.base import Fault, FaultParams, Layer, NoParams, Timing


class ImuSilence(Fault[NoParams]):
    """The XSENS stops streaming (a cut line inside the device): no data messages; it keeps
    counting, so the packet counter jumps when data return."""

    kind = "imu.silence"
    layer = Layer.DEVICE
    Params = NoParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "imu"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.imu_silence.add(self, t_ns)
        return {"streaming": False}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.imu_silence.remove(self, t_ns)
        return {"streaming": not self.env.imu_silence.items}


class ImuReset(Fault[NoParams]):
    """The XSENS resets (brown-out): power cycle at t_s, WakeUp, then the stored configuration
    (turn-on errors drawn again, counters cleared)."""

    kind = "imu.reset"
    layer = Layer.DEVICE
    timing = Timing.INSTANT
    Params = NoParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "imu"

    def apply(self, t_ns: int) -> dict[str, Any]:
        imu = self.env.devices.imu
        before = imu.state.name
        imu.power_cycle(t_ns)
        return {"state_before": before, "state": imu.state.name}


class CounterJumpParams(FaultParams):
    delta: int = Field(default=100, ge=1, le=0xFFFF, description="added to the packet/sample counter (mod 2^16)")


class ImuCounterJump(Fault[CounterJumpParams]):
    """The XSENS packet counter (legacy: sample counter) jumps by ``delta``."""

    kind = "imu.counter_jump"
    layer = Layer.DEVICE
    timing = Timing.INSTANT
    Params = CounterJumpParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "imu"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.imu.jump_packet_counter(self.params.delta)
        return {"delta": self.params.delta}


FAULTS: tuple[type[Fault[Any]], ...] = (ImuSilence, ImuReset, ImuCounterJump)
