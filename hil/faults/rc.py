"""RC receiver faults: PPM signal loss, glitches, channel count, a stuck channel; SBUS flags.

They use the PPM generator's fault hooks ``PpmGenerator.inject_glitch / set_channel_count /
set_stuck`` and, for loss, the stick script's ``signal_present`` (env.RcLossGate wraps the
script). They act on the PPM train, upstream of the front-end, so they apply to capture and
SBUS rigs alike, except ``rc.sbus_flags``, which sets flag bits in the SBUS frames on the
wire (SBUS rigs only).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from pydantic import Field

from emulators.rc.sbus import SbusFlag
from emulators.rc.script import CENTRE_US
from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, NoParams, Refused
from hil.faults.framing import Direction, Protocol, split
from hil.faults.wire import WireFault


def _check_channel(channel: int, rig: Any) -> None:
    n = rig.rc.ppm.n_channels
    if not 1 <= channel <= n:
        raise Refused("channel", f"this rig's receiver sends {n} channels (1..{n})")


class RcSignalLoss(Fault[NoParams]):
    """The receiver stops sending PPM (out of range, transmitter off): no pulses for frames
    starting in [t_s, t_s + duration_s)."""

    kind = "rc.signal_loss"
    layer = Layer.DEVICE
    Params = NoParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "rc"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.window = self.env.rc_gate.open(self.t_start_ns, self.end_ns)
        return {"ppm": "lost"}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.rc_gate.close(self.window, t_ns)
        return {"ppm": "back"}


class GlitchParams(FaultParams):
    channel: int = Field(default=3, ge=1, le=16, description="channel (1-based) whose slot gets the extra pulse")
    width_us: int = Field(default=20, ge=1, le=1000, description="width of the glitch pulse, us")
    interval_s: float = Field(
        default=0.0225, gt=0.0, description="with duration_s: one glitch every interval_s (22.5 ms = every frame)"
    )


class RcGlitch(Fault[GlitchParams]):
    """Glitch pulses on the PPM line: an extra pulse splits a channel in two. Without
    duration_s one glitch (the first frame at or after t_s), else one every interval_s."""

    kind = "rc.glitch"
    layer = Layer.DEVICE
    Params = GlitchParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _check_channel(params.channel, rig)
        ppm = rig.rc.ppm
        # The generator only inserts a glitch that fits inside the slot with margin
        # (emulators/rc/ppm.py); check against the shortest slot, a 1000 us channel.
        need_us = params.width_us + 2 * ppm.jitter_clip_us + 2
        if need_us >= 1000 - ppm.separator_us:
            raise Refused("width_us", f"does not fit in a 1000 us channel slot after the {ppm.separator_us} us separator")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"rc ch{params.channel}"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.next_ns = self.t_start_ns
        self.count = 0
        self._inject(t_ns)
        return {"channel": self.params.channel, "width_us": self.params.width_us}

    def update(self, t_ns: int) -> None:
        self._inject(t_ns)

    def _inject(self, t_ns: int) -> None:
        if self.end_ns is None and self.count:
            return  # a single glitch
        step = round(self.params.interval_s * NS_PER_S)
        while self.next_ns <= t_ns and (self.end_ns is None or self.next_ns < self.end_ns):
            self.env.devices.ppm.inject_glitch(self.next_ns, self.params.width_us, self.params.channel)
            self.count += 1
            self.next_ns += step
            if self.end_ns is None:
                return

    def revert(self, t_ns: int) -> dict[str, Any]:
        return {"glitches": self.count}


class ChannelCountParams(FaultParams):
    n_channels: int = Field(ge=1, le=16, description="channels per PPM frame while the fault lasts")


class RcChannelCount(Fault[ChannelCountParams]):
    """The receiver sends a different number of channels (wrong receiver mode/binding)."""

    kind = "rc.channel_count"
    layer = Layer.DEVICE
    Params = ChannelCountParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if params.n_channels == rig.rc.ppm.n_channels:
            raise Refused("n_channels", f"this rig already sends {params.n_channels} channels")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "rc"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.ppm.set_channel_count(self.t_start_ns, self.params.n_channels)
        return {"n_channels": self.params.n_channels}

    def revert(self, t_ns: int) -> dict[str, Any]:
        n = self.env.devices.rig.rc.ppm.n_channels
        self.env.devices.ppm.set_channel_count(self.exact_end(t_ns), n)
        return {"n_channels": n}


class ChannelStuckParams(FaultParams):
    channel: int = Field(ge=1, le=16, description="channel (1-based)")
    pulse_us: int | None = Field(
        default=None, ge=800, le=2200, description="stuck width, us; omitted: the value at t_s"
    )


class RcChannelStuck(Fault[ChannelStuckParams]):
    """One RC channel is stuck (a broken stick pot, a frozen encoder)."""

    kind = "rc.channel_stuck"
    layer = Layer.DEVICE
    Params = ChannelStuckParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _check_channel(params.channel, rig)

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"rc ch{params.channel}"

    def apply(self, t_ns: int) -> dict[str, Any]:
        ppm = self.env.devices.ppm
        ch = self.params.channel
        pulse = self.params.pulse_us
        if pulse is None:  # what the generator would send now (rounded, clamped; unscripted: centred)
            scripted = ppm.script.pulses_us(self.t_start_ns)
            pulse = scripted[ch - 1] if ch <= len(scripted) else CENTRE_US
        ppm.set_stuck(self.t_start_ns, ch, pulse)
        return {"channel": ch, "pulse_us": pulse}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.ppm.set_stuck(self.exact_end(t_ns), self.params.channel, None)
        return {"channel": self.params.channel, "pulse_us": None}


SBUS_FLAGS_INDEX = 23  # 0F, 22 channel bytes, flags, end (emulators/rc/sbus.py)


class SbusFlagParams(FaultParams):
    failsafe: bool = Field(default=True, description="set the failsafe bit (flags bit 3)")
    frame_lost: bool = Field(default=True, description="set the frame-lost bit (flags bit 2)")


class SbusFlags(WireFault[Any]):
    """The SBUS receiver reports failsafe / frame lost while the channels keep coming (a
    converter or receiver bug): the flags byte of every SBUS frame gets these bits. Only on
    rigs whose RC front-end is SBUS."""

    kind = "rc.sbus_flags"
    layer = Layer.DEVICE
    Params = SbusFlagParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if rig.rc.frontend != "sbus":
            raise Refused("kind", f"this rig's RC front-end is {rig.rc.frontend!r}, not SBUS")
        if not (params.failsafe or params.frame_lost):
            raise Refused("failsafe", "neither bit set: the fault would change nothing")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "rc SBUS flags"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.active = True
        self.counters = Counter()
        self.protocols = {Direction.TX: Protocol.SBUS}
        self.bits = (int(SbusFlag.FAILSAFE) if self.params.failsafe else 0) | (int(SbusFlag.FRAME_LOST) if self.params.frame_lost else 0)
        self.env.add_filter("rc", self)
        return {"flags_or": self.bits}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.active = False
        return {"frames": self.counters["frames_hit"]}

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        out = bytearray()
        for seg, is_frame in split(Protocol.SBUS, data):
            if is_frame:
                self.counters["frames_hit"] += 1
                seg = seg[:SBUS_FLAGS_INDEX] + bytes((seg[SBUS_FLAGS_INDEX] | self.bits,)) + seg[SBUS_FLAGS_INDEX + 1 :]
            out += seg
        return bytes(out)


FAULTS: tuple[type[Fault[Any]], ...] = (RcSignalLoss, RcGlitch, RcChannelCount, RcChannelStuck, SbusFlags)
