"""A DeviceSet of the default rig on in-memory ports, stepped tick by tick like hil/flight/tickloop.py,
with a FaultSchedule in front; helpers to talk to the devices as the flight code would.

No flight code runs: the tests write what it would write (Xbus, Bus Pirate SPI, Maestro,
XBee API) and read what it would read.
"""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import struct
from collections.abc import Sequence
from typing import Any

from emulators.mcp3204 import fig61_decode, fig61_request
from emulators.rc.capture import CaptureWire, unpack_record
from emulators.rc.script import StickScript
from emulators.xsens.codec import FrameParser
from emulators.xsens.defs import MID, XDI
from emulators.xsens.mtdata2 import unpack_packets
from hil.flight.devices import DeviceSet
from hil.faults import FaultSchedule, ScheduledFault
from hil.config.rig import Rig
from hil.transport.memory import MemoryPort

PORTS = ("imu", "adc", "rc", "esc", "telemetry", "ground")
TICK_NS = 2_500_000
S = 1_000_000_000

#: The flight code's mk4 output configuration (flightcode/drivers/xbus.py): counter, time,
#: Euler (NED), rate of turn, acceleration (FRD), status word, every sample at 400 Hz.
FLIGHT_OUTPUT = ((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400), (0xE020, 0xFFFF))


def flight_rig(rig: Rig) -> Rig:
    """The default rig with the XSENS streaming what the flight code configures."""
    return dataclasses.replace(rig, imu=dataclasses.replace(rig.imu, output_configuration=FLIGHT_OUTPUT))


class Bench:
    """Devices + ports + a fault schedule; ``await tick()`` runs one bench tick."""

    def __init__(
        self,
        rig: Rig,
        faults: Sequence[ScheduledFault] = (),
        *,
        seed: int = 1,
        script: StickScript | None = None,
        flight: Any = None,
    ) -> None:
        self.devices = DeviceSet(rig, seed=seed, stick_script=script or StickScript([]))
        self.ports = {name: MemoryPort(name) for name in PORTS}
        self.devices.attach(dict(self.ports))
        self.events: list[tuple[int, str, str, dict[str, Any]]] = []
        self.schedule = FaultSchedule(faults, self.devices, log_event=self._log, flight=flight)
        self.k = 0
        #: per port: (t_ns, bytes) of every chunk the client received, tick by tick
        self.rx: dict[str, list[tuple[int, bytes]]] = {name: [] for name in PORTS}
        #: plant truth at each tick (what the sensors were given)
        self.truth: list[Any] = []

    def _log(self, t_ns: int, kind: str, name: str, detail: dict[str, Any]) -> None:
        self.events.append((t_ns, kind, name, detail))

    @property
    def t_ns(self) -> int:
        return self.k * TICK_NS

    async def tick(self, n: int = 1) -> None:
        """``n`` ticks in the order of hil/flight/tickloop.py (scenario/faults, plant, RC, analog, IMU, rest)."""
        d = self.devices
        for _ in range(n):
            t = self.k * TICK_NS
            self.schedule.before_tick(t)
            d.actuate_and_step(t)
            self.truth.append(d.plant.sensors())
            await d.emit_rc(t)
            d.latch_analog(t)
            d.emit_imu(t)
            d.finish_tick(t)
            for name, port in self.ports.items():
                data = port.client.read_now()
                if data:
                    self.rx[name].append((t, data))
            self.k += 1

    async def run_to(self, t_s: float) -> None:
        """Tick until sim time reaches ``t_s`` (inclusive)."""
        end = round(t_s * S)
        while self.k * TICK_NS <= end:
            await self.tick()

    async def write(self, port: str, data: bytes) -> None:
        """The client writes ``data``; delivered to the device at the current sim time."""
        self.ports[port].client.write(data)
        await asyncio.sleep(0)  # MemoryClient delivers with call_soon

    def received(self, port: str, t0_s: float = 0.0, t1_s: float = 1e9) -> bytes:
        """Bytes the client got in ticks with t0 <= t < t1."""
        a, b = round(t0_s * S), round(t1_s * S)
        return b"".join(d for t, d in self.rx[port] if a <= t < b)

    def chunks(self, port: str, t0_s: float = 0.0, t1_s: float = 1e9) -> list[tuple[int, bytes]]:
        a, b = round(t0_s * S), round(t1_s * S)
        return [(t, d) for t, d in self.rx[port] if a <= t < b]

    def fault_events(self, suffix: str = "") -> list[tuple[int, str, dict[str, Any]]]:
        return [(t, name, d) for t, kind, name, d in self.events if kind == "fault" and name.endswith(suffix)]


# -- IMU (Xbus) -----------------------------------------------------------------------------------
def xbus_frames(data: bytes) -> tuple[list[Any], FrameParser]:
    parser = FrameParser(max_payload=0xFFFF)  # the mk4's eMTS message is 1320 bytes
    return parser.feed(data), parser


def imu_samples(data: bytes) -> list[dict[str, Any]]:
    """Decoded MTData2 samples: counter, stf, euler_deg, rate_radps, acc_mps2 (float32)."""
    frames, _ = xbus_frames(data)
    out = []
    for f in frames:
        if f.mid != MID.MTDATA2:
            continue
        s: dict[str, Any] = {}
        for xdi, raw in unpack_packets(f.payload):
            kind = xdi & 0xFFF0
            if kind == XDI.PACKET_COUNTER:
                s["counter"] = struct.unpack(">H", raw)[0]
            elif kind == XDI.SAMPLE_TIME_FINE:
                s["stf"] = struct.unpack(">I", raw)[0]
            elif kind == XDI.EULER_ANGLES:
                s["euler_deg"] = struct.unpack(">3f", raw)
            elif kind == XDI.RATE_OF_TURN:
                s["rate_radps"] = struct.unpack(">3f", raw)
            elif kind == XDI.ACCELERATION:
                s["acc_mps2"] = struct.unpack(">3f", raw)
            elif kind == XDI.STATUS_WORD:
                s["status"] = struct.unpack(">I", raw)[0]
        out.append(s)
    return out


# -- ADC (Bus Pirate binary SPI + MCP3204), as tests/unit/adc/test_buspirate.py does ----------------
async def adc_enter_spi(b: Bench) -> None:
    await b.write("adc", b"\x00" * 20 + b"\x01")
    await b.write("adc", b"\x8a")  # 3.3 V push-pull, idle low, active-to-idle: SPI mode 0
    b.ports["adc"].client.read_now()


async def adc_read(b: Bench, channel: int) -> int:
    """One MCP3204 conversion of ``channel`` through the Bus Pirate (CS low, 3 bytes, CS high)."""
    client = b.ports["adc"].client
    client.read_now()
    await b.write("adc", b"\x02\x12" + fig61_request(channel) + b"\x03")
    rx = client.read_now()
    assert rx[:2] == b"\x01\x01" and rx[-1:] == b"\x01", rx
    return fig61_decode(rx[2:5])


async def adc_series(b: Bench, channels: Sequence[int], n_ticks: int) -> list[list[int]]:
    """Tick ``n_ticks`` times, reading ``channels`` after each tick's analog latch."""
    out = []
    for _ in range(n_ticks):
        await b.tick()
        out.append([await adc_read(b, ch) for ch in channels])
    return out


# -- ESC (Maestro compact protocol) ----------------------------------------------------------------
def set_multiple_targets(pulse_us: Sequence[float]) -> bytes:
    """Maestro Set Multiple Targets (0x9F) for channels 0..n-1, targets in quarter-us."""
    out = bytearray((0x9F, len(pulse_us), 0))
    for us in pulse_us:
        q = round(us * 4)
        out += bytes((q & 0x7F, (q >> 7) & 0x7F))
    return bytes(out)


async def arm_and_spin(b: Bench, pulse_us: float, *, arm_s: float = 0.6) -> None:
    """Low throttle for ``arm_s`` (the ESCs arm after 0.5 s), then ``pulse_us`` on all four."""
    await b.write("esc", set_multiple_targets([1000.0] * 4))
    await b.run_to(b.t_ns / S + arm_s)
    await b.write("esc", set_multiple_targets([pulse_us] * 4))


# -- RC capture records ------------------------------------------------------------------------------
def capture_records(data: bytes) -> list[Any]:
    n = CaptureWire.RECORD_LEN
    recs = [unpack_record(data[i : i + n]) for i in range(0, len(data) - n + 1, n)]
    assert all(r is not None for r in recs), "capture stream out of step"
    return recs


def falling_edge_times_us(records: Sequence[Any]) -> list[int]:
    """Unwrapped 16-bit capture times of the falling edges (separator starts, idle-high PPM)."""
    out, base, last = [], 0, None
    for r in records:
        if last is not None and r.capture_us < last:
            base += CaptureWire.TIMER_MODULUS
        last = r.capture_us
        if not r.level:
            out.append(base + r.capture_us)
    return out


def ppm_frames(records: Sequence[Any], sync_min_us: int = 2700) -> list[list[int]]:
    """Channel widths per frame from separator-start intervals (a gap >= sync ends a frame)."""
    times = falling_edge_times_us(records)
    frames: list[list[int]] = []
    cur: list[int] = []
    for a, b in itertools.pairwise(times):
        w = b - a
        if w >= sync_min_us:
            if cur:
                frames.append(cur)
            cur = []
        else:
            cur.append(w)
    return frames
