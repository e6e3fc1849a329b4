"""Wire faults: what happens to the bytes of one port, in either direction.

A wire fault is itself the port's filter (hil/flight/devices.py ``WireFilter``): while it is in
``devices.wire_filters[port]``, ``tx(data, t_ns)`` sees every chunk the device writes to
the flight code, ``rx(data, t_ns)`` every chunk the flight code writes to the device, and
``poll(t_ns)`` (once per tick) releases bytes held back. When the fault ends it stops
changing bytes; a delay keeps releasing what it holds (in order) and is taken out of the
port once empty (``finished``).

Frame-level faults use hil/faults/framing.py to find the frames of the port's protocol;
where the protocol has no frames a chunk (one write) stands for a frame. Baud mismatch
re-clocks the 8N1 bit stream at the wrong rate with the XSENS model's UART receiver
(emulators/xsens/uart.py), so the garbage is what a real UART delivers.
"""

from __future__ import annotations

from collections import Counter, deque
from typing import Any, ClassVar, Literal, TypeVar

import numpy as np
from pydantic import Field, model_validator

from emulators.xbee.params import BD_RATES
from emulators.xsens.uart import receive_at_wrong_baud
from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, Refused
from hil.faults.framing import (
    RIG_PORTS,
    WITH_CHECKSUM,
    Direction,
    Protocol,
    corrupt_checksum,
    flip_last_byte,
    protocol_of,
    split,
)


#: the ports of a board run (hil/flight/board_run.py): the UARTs' devices and the ground station
BOARD_PORTS: tuple[str, ...] = ("imu", "telemetry", "ground")
#: the wire faults that also act on a board's SPI lines to the MCP3204 (the adc port: tx is MISO,
#: rx is MOSI; hil/flight/board_wiring.py): the master clocks every bit, so only a fault that
#: changes bits has a meaning there, not one that drops, adds, frames or delays bytes
SPI_LINE_FAULTS: tuple[str, ...] = ("wire.bit_flips", "wire.silence")


class WireParams(FaultParams):
    port: str = Field(description=f"the port: {', '.join(RIG_PORTS)}")
    direction: Direction = Field(
        default=Direction.TX, description="'tx' device -> flight code, 'rx' flight code -> device, or 'both'"
    )


def _directions(d: Direction) -> tuple[Direction, ...]:
    return (Direction.TX, Direction.RX) if d is Direction.BOTH else (d,)


WP = TypeVar("WP", bound=WireParams)


class WireFault(Fault[WP]):
    """Base of the wire faults: checks the port and direction, installs itself as a filter."""

    layer = Layer.WIRE
    Params: ClassVar[type[FaultParams]] = WireParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if params.port not in RIG_PORTS:
            raise Refused("port", f"no port {params.port!r} on this rig (ports: {', '.join(RIG_PORTS)})")
        on_spi_lines = params.port == "adc" and cls.kind in SPI_LINE_FAULTS  # MISO (tx), MOSI (rx), bit by bit
        if rig.flight.board and params.port not in BOARD_PORTS and not on_spi_lines:
            if params.port == "adc":
                raise Refused("kind", f"on this rig's board ({rig.flight.board}) the adc is the MCP3204 on SPI0, "
                                      "whose master clocks every bit: of the wire faults only "
                                      f"{' and '.join(SPI_LINE_FAULTS)} act on its lines")
            else:
                raise Refused("port", f"on this rig's board ({rig.flight.board}) the {params.port} device is wired at "
                                      f"the MCU's pins, not through a byte stream: wire faults act on "
                                      f"{', '.join(BOARD_PORTS)} (the UARTs' bytes) and {' and '.join(SPI_LINE_FAULTS)} "
                                      "on adc (SPI0's lines); the device and sensor faults act on it")
        for d in _directions(params.direction):
            if protocol_of(rig, params.port, d) is Protocol.NONE:
                raise Refused("direction", f"the flight code sends nothing on {params.port!r}; use direction = 'tx'")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"port {params.port} {params.direction.value}"

    # -- life cycle ------------------------------------------------------------------------------
    def apply(self, t_ns: int) -> dict[str, Any]:
        self.active = True
        self.counters: Counter[str] = Counter()
        rig = self.env.devices.rig
        self.protocols = {d: protocol_of(rig, self.params.port, d) for d in _directions(self.params.direction)}
        self.env.add_filter(self.params.port, self)
        return {"port": self.params.port, "direction": self.params.direction.value} | self.applied()

    def applied(self) -> dict[str, Any]:
        return {}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.active = False
        return {"port": self.params.port, "counts": dict(self.counters)}

    @property
    def finished(self) -> bool:
        """Ended and holding nothing: the schedule takes it off the port."""
        return not self.active

    # -- the WireFilter protocol -----------------------------------------------------------------
    def tx(self, data: bytes, t_ns: int) -> bytes:
        return self._filter(data, t_ns, Direction.TX)

    def rx(self, data: bytes, t_ns: int) -> bytes:
        return self._filter(data, t_ns, Direction.RX)

    def poll(self, t_ns: int) -> bytes:
        return b""

    def _filter(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        if not data or d not in self.protocols:
            return data
        if not self.active:
            return self.after_end(data, t_ns, d)
        self.counters[f"{d.value}_bytes_in"] += len(data)
        out = self.process(data, t_ns, d)
        self.counters[f"{d.value}_bytes_out"] += len(out)
        return out

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        raise NotImplementedError

    def after_end(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        return data


class Silence(WireFault[WireParams]):
    """The line goes dead (unplugged connector, cut wire): no bytes pass."""

    kind = "wire.silence"

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        return b""


class ByteLossParams(WireParams):
    loss_probability: float = Field(gt=0.0, le=1.0, description="probability that a byte is lost")


class ByteLoss(WireFault[ByteLossParams]):
    """Bytes go missing independently (a receiver overrun, a marginal connection)."""

    kind = "wire.byte_loss"
    Params = ByteLossParams

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        keep = self.rng.random(len(data)) >= self.params.loss_probability
        return bytes(np.frombuffer(data, dtype=np.uint8)[keep])


class BitFlipParams(WireParams):
    bit_error_rate: float = Field(gt=0.0, le=0.5, description="probability that a data bit is inverted")


class BitFlips(WireFault[BitFlipParams]):
    """Bit errors (noise on the line): each data bit inverted with probability bit_error_rate."""

    kind = "wire.bit_flips"
    Params = BitFlipParams

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        flips = self.rng.random(8 * len(data)) < self.params.bit_error_rate
        if not flips.any():
            return data
        self.counters["bits_flipped"] += int(flips.sum())
        mask = np.packbits(flips, bitorder="little")
        return bytes(np.frombuffer(data, dtype=np.uint8) ^ mask)


class FrameParams(WireParams):
    probability: float = Field(default=1.0, gt=0.0, le=1.0, description="fraction of frames affected")


FP = TypeVar("FP", bound=FrameParams)


class _FrameFault(WireFault[FP]):
    """Acts on the frames of the port's protocol (a chunk where there are none)."""

    Params = FrameParams

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        proto = self.protocols[d]
        out = bytearray()
        for seg, is_frame in split(proto, data):
            if is_frame and self.rng.random() < self.params.probability:
                self.counters["frames_hit"] += 1
                out += self.frame(seg, proto)
            else:
                out += seg
        return bytes(out)

    def frame(self, frame: bytes, proto: Protocol) -> bytes:
        raise NotImplementedError


class BadChecksumParams(FrameParams):
    mode: Literal["protocol", "last_byte"] = Field(
        default="protocol",
        description="'protocol': corrupt the checksum of each frame (Xbus, capture CRC-8, XBee API, Maestro CRC-7); "
        "'last_byte': flip the last byte of each chunk, any port",
    )


class BadChecksum(_FrameFault[BadChecksumParams]):
    """Frames arrive with a wrong checksum (the receiver must drop them)."""

    kind = "wire.bad_checksum"
    Params = BadChecksumParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        if params.mode == "protocol":
            for d in _directions(params.direction):
                proto = protocol_of(rig, params.port, d)
                if proto not in WITH_CHECKSUM:
                    raise Refused(
                        "port",
                        f"{proto.value} on {params.port!r} ({d.value}) has no checksum; "
                        "use mode = 'last_byte' or wire.bit_flips",
                    )

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        if self.params.mode == "last_byte":
            if self.rng.random() >= self.params.probability:
                return data
            self.counters["frames_hit"] += 1
            return flip_last_byte(data, self.rng)
        return super().process(data, t_ns, d)

    def frame(self, frame: bytes, proto: Protocol) -> bytes:
        return corrupt_checksum(proto, frame, self.rng)


class Truncate(_FrameFault[FrameParams]):
    """Frames are cut short (a receiver dropping the tail): each hit frame keeps a random
    1 .. n-1 of its n bytes."""

    kind = "wire.truncate"

    def frame(self, frame: bytes, proto: Protocol) -> bytes:
        if len(frame) < 2:
            return frame
        return frame[: int(self.rng.integers(1, len(frame)))]


class Duplicate(_FrameFault[FrameParams]):
    """Frames arrive twice (a retransmitting bridge, a buffer replayed)."""

    kind = "wire.duplicate"

    def frame(self, frame: bytes, proto: Protocol) -> bytes:
        return frame + frame


class DelayParams(WireParams):
    delay_s: float = Field(default=0.0, ge=0.0, le=10.0, description="added latency, s (sim time)")
    jitter_s: float = Field(default=0.0, ge=0.0, le=10.0, description="plus a uniform random 0..jitter_s per chunk, s")


class Delay(WireFault[DelayParams]):
    """Added latency and jitter on the way to the flight code (a busy USB-serial bridge).

    Chunks are held and released by the tick loop's poll once their time has come (a tick's
    resolution); the order of bytes is kept, as on a serial line."""

    kind = "wire.delay"
    Params = DelayParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        if params.direction is not Direction.TX:
            raise Refused("direction", "the bench can only hold back device -> flight code bytes; use 'tx'")
        if params.delay_s == 0.0 and params.jitter_s == 0.0:
            raise Refused("delay_s", "delay_s and jitter_s are both 0: the fault would change nothing")

    def applied(self) -> dict[str, Any]:
        self.held: deque[tuple[int, bytes]] = deque()
        self.last_release_ns = -(1 << 62)
        return {"delay_s": self.params.delay_s, "jitter_s": self.params.jitter_s}

    def _hold(self, data: bytes, release_ns: int) -> bytes:
        release_ns = max(release_ns, self.last_release_ns)  # a serial line keeps the byte order
        self.last_release_ns = release_ns
        self.held.append((release_ns, data))
        return b""

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        p = self.params
        delay_ns = p.delay_s * NS_PER_S + (self.rng.uniform(0.0, p.jitter_s) * NS_PER_S if p.jitter_s else 0.0)
        return self._hold(data, t_ns + round(delay_ns))

    def after_end(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        return self._hold(data, t_ns) if self.held else data

    def poll(self, t_ns: int) -> bytes:
        out = bytearray()
        while self.held and self.held[0][0] <= t_ns:
            out += self.held.popleft()[1]
        return bytes(out)

    @property
    def finished(self) -> bool:
        return not self.active and not self.held


class BaudParams(WireParams):
    device_baud_bps: int | None = Field(default=None, gt=0, description="the device's (wrong) line rate, bit/s")
    rate_error: float | None = Field(
        default=None, ge=-0.5, le=1.0, description="or: device rate = the port's rate x (1 + rate_error), e.g. 0.06 = +6 %"
    )

    @model_validator(mode="after")
    def _one(self) -> BaudParams:
        if (self.device_baud_bps is None) == (self.rate_error is None):
            raise ValueError("give exactly one of device_baud_bps and rate_error")
        return self


def nominal_baud_bps(rig: Any, port: str) -> int:
    """The line rate the rig runs ``port`` at (what the flight code is configured for)."""
    if port == "imu":
        return int(rig.imu.baud_bps)
    if port == "adc":
        return int(rig.adc.buspirate.baud_bps)
    if port == "rc":
        return int(rig.rc.capture.baud if rig.rc.frontend == "capture" else rig.rc.sbus.baud)
    if port == "esc":
        return int(rig.esc.maestro.baud)
    bd = (rig.telemetry.vehicle if port == "telemetry" else rig.telemetry.ground).bd
    return BD_RATES[bd] if bd < len(BD_RATES) else int(bd)


class BaudMismatch(WireFault[BaudParams]):
    """The device's UART runs at the wrong rate (bad crystal, wrong setting): the flight
    code receives what a UART at its own rate makes of the re-clocked bit stream (garbage,
    framing errors delivered as 00, fewer or more bytes), and the device garbles what the
    flight code sends the same way.

    The host's rate is the one it opened the port with (the rig's rate until it does). The
    fault assumes the host is at the device's configured rate; a host at yet another rate
    already gets garbage from the XSENS and XBee models, which this re-clocks once more."""

    kind = "wire.baud_mismatch"
    Params = BaudParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        if params.port == "esc" and rig.esc.maestro.usb_command_port:
            raise Refused("port", "this rig's Maestro is on its USB command port: there is no line rate to get wrong")
        if params.device_baud_bps == nominal_baud_bps(rig, params.port) or params.rate_error == 0.0:
            raise Refused("device_baud_bps", "the rate equals the port's own: the fault would change nothing")

    def _host_bps(self) -> int:
        port = self.env.devices.ports.get(self.params.port)
        line = None if port is None else port.line  # the client's settings (Port.line; None: not known yet)
        if line is not None and line.baud:
            return int(line.baud)
        return nominal_baud_bps(self.env.devices.rig, self.params.port)

    def _device_bps(self) -> int:
        p = self.params
        if p.device_baud_bps is not None:
            return int(p.device_baud_bps)
        assert p.rate_error is not None  # the model requires one of the two
        return max(1, round(nominal_baud_bps(self.env.devices.rig, p.port) * (1.0 + p.rate_error)))

    def applied(self) -> dict[str, Any]:
        return {"host_baud_bps": self._host_bps(), "device_baud_bps": self._device_bps()}

    def process(self, data: bytes, t_ns: int, d: Direction) -> bytes:
        host = self._host_bps()
        dev = self._device_bps()
        if d is Direction.TX:
            return receive_at_wrong_baud(data, dev, host)
        return receive_at_wrong_baud(data, host, dev)


FAULTS: tuple[type[Fault[Any]], ...] = (
    Silence, ByteLoss, BitFlips, BadChecksum, Truncate, Duplicate, Delay, BaudMismatch,
)
