"""In-process fakes for the flight-code tests: pyserial-like ports driven by scripted devices.

Written from the wire documentation (docs/protocols.md, docs/rc-capture-format.md), not
from the flight code's own encoders, so a test that passes means the two agree.

:class:`FakeSerial` implements the calls the drivers make (``read``, ``write``,
``in_waiting``, ``out_waiting``, ``reset_input_buffer``, ``close``). A device attached to it
answers writes at once; reading the IMU port with nothing queued advances the whole
:class:`FakeWorld` by one 2.5 ms tick (plant step, RC edges, IMU sample) - the lockstep the
bench runs, in one process.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

TICK_NS = 2_500_000
G = 9.80665


# -- the port ----------------------------------------------------------------------------------
class FakeClock:
    """Monotonic seconds that move only when told (a fake port's read blocking, a world tick)."""

    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s

    def advance(self, dt_s: float) -> None:
        self.now_s += dt_s


class FakeSerial:
    """A pyserial-like port. ``device.on_write(data)`` answers; ``on_starve`` runs when a read finds too little.

    With a ``clock``, a read that still finds too little after ``on_starve`` advances it by
    ``timeout_s`` (the time a real read would have blocked).
    """

    def __init__(self, name: str, clock: FakeClock | None = None, timeout_s: float = 0.0) -> None:
        self.name = name
        self.clock = clock
        self.timeout_s = timeout_s
        self.rx = bytearray()
        self.written: list[bytes] = []
        self.on_write: Callable[[bytes], None] = lambda data: None
        self.on_starve: Callable[[], None] = lambda: None
        self.out_waiting = 0
        self.accept_limit: int | None = None  # write accepts at most this many bytes (short writes)
        self.closed = False
        self.reads = 0
        #: an unplugged USB adapter: every call on the hung-up tty fails with EIO
        self.unplugged = False

    def _check(self) -> None:
        if self.unplugged:
            raise OSError(5, "Input/output error")

    @property
    def in_waiting(self) -> int:
        self._check()
        return len(self.rx)

    def feed(self, data: bytes) -> None:
        self.rx += data

    def read(self, size: int = 1) -> bytes:
        self._check()
        self.reads += 1
        if len(self.rx) < size:
            self.on_starve()
            if len(self.rx) < size and self.clock is not None:
                self.clock.advance(self.timeout_s)
        out = bytes(self.rx[:size])
        del self.rx[:size]
        return out

    def write(self, data: bytes) -> int:
        self._check()
        data = bytes(data)
        if self.accept_limit is not None:
            data = data[: self.accept_limit]
        self.written.append(data)
        self.on_write(data)
        return len(data)

    def reset_input_buffer(self) -> None:
        self.rx.clear()

    def close(self) -> None:
        self.closed = True


# -- XSENS -------------------------------------------------------------------------------------
def xbus(mid: int, payload: bytes = b"") -> bytes:
    """Xbus frame (docs/protocols.md 1.2): FA FF MID LEN DATA CS, bytes after FA sum to 0."""
    body = bytes((0xFF, mid, len(payload))) + payload
    return b"\xfa" + body + bytes(((-sum(body)) & 0xFF,))


class FakeXsens:
    """A mk4 (MTData2) or legacy (MTData) MTi: config state machine and the sample stream."""

    def __init__(self, port: FakeSerial, legacy: bool = False, device_id: int = 0x037003F8) -> None:
        self.port = port
        self.legacy = legacy
        self.device_id = device_id
        self.measuring = False
        self.silent = False  # fault: answers nothing at all
        self.refuse: set[int] = set()  # MIDs answered with Error 0x04
        self.output_config: bytes = b""
        self.counter = 0
        self.requests: list[int] = []
        self._buf = bytearray()
        port.on_write = self._on_write

    def _on_write(self, data: bytes) -> None:
        self._buf += data
        while True:
            i = self._buf.find(b"\xfa\xff")
            if i < 0 or len(self._buf) < i + 5:
                return
            n = self._buf[i + 3]
            if len(self._buf) < i + 5 + n:
                return
            frame = bytes(self._buf[i : i + 5 + n])
            del self._buf[: i + 5 + n]
            if sum(frame[1:]) & 0xFF == 0:
                self._handle(frame[2], frame[4:-1])

    def _handle(self, mid: int, payload: bytes) -> None:
        self.requests.append(mid)
        if self.silent:
            return
        if mid in self.refuse:
            self.port.feed(xbus(0x42, b"\x04"))
            return
        if mid == 0x30:
            self.measuring = False
            self.port.feed(xbus(0x31))
        elif mid == 0x00:
            self.port.feed(xbus(0x01, self.device_id.to_bytes(4, "big")))
        elif mid == 0x1C:
            self.port.feed(xbus(0x1D, b"MTi-28A53G35" if self.legacy else b"MTi-100-2A8G4       "))
        elif mid == 0x12:
            self.port.feed(xbus(0x13, bytes((2, 4, 6) if self.legacy else (1, 8, 2))))
        elif mid == 0xC0 and not self.legacy:
            self.output_config = payload
            self.port.feed(xbus(0xC1, payload))
        elif mid in (0xD0, 0xD2, 0x04) and self.legacy:
            self.port.feed(xbus(mid + 1))
        elif mid == 0x10:
            self.port.feed(xbus(0x11))
            self.measuring = True
        else:
            self.port.feed(xbus(0x42, b"\x04"))

    def sample(self, t_ns: int, euler_deg: tuple[float, float, float], gyr: tuple[float, float, float],
               acc: tuple[float, float, float], status: int = 0x00000003) -> bytes:
        """The sample frame for sim time ``t_ns`` (SampleTimeFine = t / 100 us + 1000 offset)."""
        self.counter = (self.counter + 1) & 0xFFFF
        if self.legacy:
            payload = struct.pack(">3f3f3f3fH", *acc, *gyr, 0.5, 0.0, 0.8, *euler_deg, self.counter)
            return xbus(0x32, payload)
        stf = (t_ns // 100_000 + 1000) & 0xFFFFFFFF
        payload = (struct.pack(">HBH", 0x1020, 2, self.counter) + struct.pack(">HBI", 0x1060, 4, stf)
                   + struct.pack(">HB3f", 0x2034, 12, *euler_deg) + struct.pack(">HB3f", 0x8024, 12, *gyr)
                   + struct.pack(">HB3f", 0x4024, 12, *acc) + struct.pack(">HBI", 0xE020, 4, status))
        return xbus(0x36, payload)


# -- Bus Pirate + MCP3204 ------------------------------------------------------------------------
class FakeBusPirate:
    """Bus Pirate v3 binary mode (docs/protocols.md 7.1) with an MCP3204 on its SPI bus."""

    def __init__(self, port: FakeSerial, codes: Callable[[int], int]) -> None:
        self.port = port
        self.codes = codes  # channel -> 12-bit code now
        self.mode = "terminal"
        self.zeros = 0
        self.cs_low = False
        self.dead = False
        self.garbage_next: bytes = b""  # fault: these bytes replace the next reply
        self.transactions = 0
        self.config_bytes: list[int] = []
        self._pending = bytearray()
        port.on_write = self._on_write

    def _reply(self, data: bytes) -> None:
        if self.garbage_next:
            data, self.garbage_next = self.garbage_next, b""
        self.port.feed(data)

    def _on_write(self, data: bytes) -> None:
        if self.dead:
            return
        self._pending += data
        while self._pending:
            b = self._pending[0]
            if self.mode == "terminal":
                del self._pending[:1]
                self.zeros = self.zeros + 1 if b == 0 else 0
                if self.zeros >= 20:
                    self.mode, self.zeros = "bbio", 0
                    self._reply(b"BBIO1")
            elif self.mode == "bbio":
                del self._pending[:1]
                if b == 0x00:
                    self._reply(b"BBIO1")
                elif b == 0x01:
                    self.mode = "spi"
                    self._reply(b"SPI1")
                else:
                    self._reply(b"\x00")
            else:
                if 0x10 <= b <= 0x1F:
                    n = (b & 0x0F) + 1
                    if len(self._pending) < 1 + n:
                        return
                    mosi = bytes(self._pending[1 : 1 + n])
                    del self._pending[: 1 + n]
                    self._reply(b"\x01" + self._mcp3204(mosi))
                    continue
                del self._pending[:1]
                if b == 0x00:
                    self.mode = "bbio"
                    self._reply(b"BBIO1")
                elif b == 0x01:
                    self._reply(b"SPI1")
                elif b in (0x02, 0x03):
                    self.cs_low = b == 0x02
                    self._reply(b"\x01")
                elif b & 0xF0 in (0x40, 0x60, 0x80):
                    self.config_bytes.append(b)
                    self._reply(b"\x01")
                else:
                    self._reply(b"\x00")

    def _mcp3204(self, mosi: bytes) -> bytes:
        """The flight code's framing only: ``0 1 S D2 D1 D0 0 0`` and three bytes, in which the
        part sends the null bit, B11..B0 and B1..B11 again LSB first."""
        assert self.cs_low, "transfer with CS high"
        if len(mosi) != 4 or mosi[0] & 0xC3 != 0x40:
            return b"\xff" * len(mosi)
        channel = (mosi[0] >> 2) & 7
        code = self.codes(channel & 3)
        self.transactions += 1
        repeat = int(f"{code >> 1:011b}"[::-1], 2)  # B1 first
        word = (code << 12) | (repeat << 1)  # B11..B0, B1..B11, a zero: 24 bits
        # byte 0's hi-Z bits read 1 here (a pull-up), its last bit is the null bit
        return bytes((0xFE, word >> 16, (word >> 8) & 0xFF, word & 0xFF))


# -- RC ------------------------------------------------------------------------------------------
def crc8_07(data: bytes) -> int:
    """CRC-8 poly 0x07, init 0 (docs/rc-capture-format.md)."""
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def capture_record(seq: int, level: int, t_us: int, overrun: bool = False) -> bytes:
    body = bytes((seq & 0xFF, level | (2 if overrun else 0), t_us & 0xFF, (t_us >> 8) & 0xFF))
    return b"\xa5" + body + bytes((crc8_07(body),))


def ppm_edges(frame_start_us: int, channels_us: list[float], separator_us: int = 300) -> list[tuple[int, int]]:
    """(time us, level after) of one idle-high PPM frame: a low separator starts each channel."""
    edges = []
    t = frame_start_us
    for width in channels_us:
        edges += [(t, 0), (t + separator_us, 1)]
        t += int(round(width))
    edges += [(t, 0), (t + separator_us, 1)]  # the last separator; then the sync gap
    return edges


class FakeCaptureRc:
    """Timer-capture front-end fed from a stick function ``sticks(t_s) -> 8 pulses or None`` (None = no signal)."""

    def __init__(self, port: FakeSerial, sticks: Callable[[float], list[float] | None], frame_us: int = 22_500,
                 timer_offset_us: int = 0xFF00) -> None:
        self.port = port
        self.sticks = sticks
        self.frame_us = frame_us
        self.timer_offset_us = timer_offset_us
        self.seq = 0
        self._next_frame_us = 0
        self._edges: list[tuple[int, int]] = []

    def advance(self, t_ns: int) -> None:
        now_us = t_ns // 1000
        while self._next_frame_us <= now_us:
            ch = self.sticks(self._next_frame_us / 1e6)
            if ch is not None:
                self._edges += ppm_edges(self._next_frame_us, ch)
            self._next_frame_us += self.frame_us
        due = [e for e in self._edges if e[0] <= now_us]
        self._edges = [e for e in self._edges if e[0] > now_us]
        out = bytearray()
        for t_us, level in due:
            out += capture_record(self.seq, level, t_us + self.timer_offset_us)
            self.seq = (self.seq + 1) & 0xFF
        self.port.feed(bytes(out))


def sbus_frame(pulses_us: list[float], flags: int = 0) -> bytes:
    """25-byte SBUS frame; raw = (pulse - 875) / 0.625 (ArduPilot scaling inverted)."""
    raw = [int(round((p - 875.0) / 0.625)) for p in pulses_us] + [992] * (16 - len(pulses_us))
    bits = 0
    for i, value in enumerate(raw):
        bits |= (value & 0x7FF) << (11 * i)
    return b"\x0f" + bits.to_bytes(22, "little") + bytes((flags, 0x00))


class FakeSbusRc:
    """PPM-to-SBUS converter: a frame every 14 ms from the same stick function."""

    def __init__(self, port: FakeSerial, sticks: Callable[[float], list[float] | None], period_us: int = 14_000):
        self.port = port
        self.sticks = sticks
        self.period_us = period_us
        self._next_us = 0

    def advance(self, t_ns: int) -> None:
        while self._next_us <= t_ns // 1000:
            ch = self.sticks(self._next_us / 1e6)
            self.port.feed(sbus_frame(ch) if ch is not None else sbus_frame([1500.0] * 8, flags=0x0C))
            self._next_us += self.period_us


# -- Maestro and XBee ------------------------------------------------------------------------------
class FakeMaestro:
    """Decodes compact Set Multiple Targets (0x9F n first (lo hi)*n) into pulses in us."""

    def __init__(self, port: FakeSerial) -> None:
        self.pulses_us = [0.0] * 4
        #: pulses after each command, us (index 0: the boot command)
        self.history: list[list[float]] = []
        self.commands = 0
        self.bad = 0
        port.on_write = self._on_write

    def _on_write(self, data: bytes) -> None:
        if len(data) < 3 or data[0] != 0x9F or len(data) != 3 + 2 * data[1]:
            self.bad += 1
            return
        n, first = data[1], data[2]
        for i in range(n):
            self.pulses_us[first + i] = (data[3 + 2 * i] | (data[4 + 2 * i] << 7)) / 4.0
        self.history.append(list(self.pulses_us))
        self.commands += 1


def xbee_frames(stream: bytes, escaped: bool) -> list[bytes]:
    """API frame data from a byte stream (docs/protocols.md 8.2), checking every checksum.

    AP=2: unescape after each 0x7E (a 0x7E inside is always escaped); AP=1: walk the stream
    by the length fields (a 0x7E may appear inside a frame).
    """
    frames = []
    if escaped:
        parts = stream.split(b"\x7e")
        assert parts[0] == b"", "bytes before the first start delimiter"
        bodies = []
        for part in parts[1:]:
            raw, i = bytearray(), 0
            while i < len(part):
                if part[i] == 0x7D:
                    raw.append(part[i + 1] ^ 0x20)
                    i += 2
                else:
                    raw.append(part[i])
                    i += 1
            bodies.append(bytes(raw))
    else:
        bodies, i = [], 0
        while i < len(stream):
            assert stream[i] == 0x7E, f"no start delimiter at offset {i}"
            n = (stream[i + 1] << 8) | stream[i + 2]
            bodies.append(stream[i + 1 : i + 4 + n])
            i += 4 + n
    for body in bodies:
        n = (body[0] << 8) | body[1]
        assert len(body) == n + 3, "frame length field disagrees with the bytes"
        data, cs = body[2 : 2 + n], body[2 + n]
        assert (sum(data) + cs) & 0xFF == 0xFF, "bad API checksum"
        frames.append(bytes(data))
    return frames


# -- the world -------------------------------------------------------------------------------------
@dataclass
class PlantState:
    """Small-angle rigid body on a flat ground (FRD body, z up for altitude)."""

    z_m: float = 0.0
    vz_mps: float = 0.0
    euler_rad: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    omega_radps: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


class FakeWorld:
    """The paper's quad on all five fake ports, stepped one tick per IMU read.

    Motor layout and signs are the shared flight-code conventions (X frame, arm 0.25 m,
    motors 0 FR CCW, 1 RL CCW, 2 FL CW, 3 RR CW; CCW reaction torque = +yaw). Thrust
    F = 5.15 N * d^2 with d = (pulse - 1000) / 1000; rotational dynamics use body rates
    directly as Euler rates (small angles).
    """

    J = (0.0153, 0.0153, 0.026)
    M_KG = 1.1
    F_MAX_MOTOR_N = 20.6 / 4
    KQ_OVER_KT_M = 0.016
    FIELD_ALT_M = 50.0

    def __init__(self, sticks: Callable[[float], list[float] | None], *, legacy_imu: bool = False,
                 rc_frontend: str = "capture", seed: int = 1, motor_tau_s: float = 0.0,
                 accel_zero_g_error_V: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 baro_ground_effect_m: float = 0.0, thrust_ground_effect_gain: float = 0.0,
                 mass_kg: float = 1.1, baro_noise_V: float = 0.24e-3) -> None:
        #: wall clock of the lockstep: a tick per sample, a read timeout per starved ADC read
        self.clock = FakeClock()
        self.ports = {name: FakeSerial(name, self.clock, 0.02 if name == "adc" else 0.0)
                      for name in ("imu", "adc", "rc", "esc", "telemetry")}
        self.rng = np.random.default_rng(seed)
        #: the MPX5100AP's own output noise, V rms at the sensor (the bench's filtered 0.5 mV
        #: comes out at 0.24 mV a sample: 3.1 codes after the x16 stage), from its own stream
        #: so that the other draws are as they were without it
        self.baro_noise_V = baro_noise_V
        self._baro_rng = np.random.default_rng([seed, 1])
        self.imu = FakeXsens(self.ports["imu"], legacy=legacy_imu)
        self.adc = FakeBusPirate(self.ports["adc"], self._adc_code)
        self.rc = (FakeCaptureRc(self.ports["rc"], sticks) if rc_frontend == "capture"
                   else FakeSbusRc(self.ports["rc"], sticks))
        self.esc = FakeMaestro(self.ports["esc"])
        self.plant = PlantState()
        self.M_KG = mass_kg  # the flight code's config says 1.1 kg whatever this is
        self.motor_tau_s = motor_tau_s
        self.accel_zero_g_error_V = accel_zero_g_error_V  # ADXL335 zero-g offsets of this unit (sensor X, Y, Z)
        #: rotor wash at the static port: the baro reads this much low on the ground at hover
        #: thrust, decaying over 0.5 m of height (the bench plant's form)
        self.baro_ground_effect_m = baro_ground_effect_m
        #: ground effect on the thrust: lift x (1 + gain exp(-z / 0.25 m)) (the ground cushion)
        self.thrust_ground_effect_gain = thrust_ground_effect_gain
        #: faults: the barometer reads this much high (m; a spike on the static port)...
        self.baro_offset_m = 0.0
        #: ...and bit errors in the data bytes of the next reply, acks intact: channel -> XOR mask
        self.code_xor: dict[int, int] = {}
        self._thrust_N = [0.0] * 4  # with motor lag: the thrust each motor actually gives
        self.k = -1  # index of the last emitted tick
        self.imu_silent_ticks: set[int] = set()
        #: lockstep delivery stalls: this many IMU reads find nothing while sim time stands still
        self.imu_stalled_reads = 0
        self.trace: list[tuple[int, float, list[float], list[float]]] = []
        self.ports["imu"].on_starve = self._tick

    @property
    def t_ns(self) -> int:
        return max(self.k, 0) * TICK_NS

    def commanded_thrusts_N(self) -> list[float]:
        out = []
        for pulse in self.esc.pulses_us[:4]:
            d = min(1.0, max(0.0, (pulse - 1000.0) / 1000.0))
            out.append(self.F_MAX_MOTOR_N * d * d)
        return out

    def thrusts_N(self) -> list[float]:
        return self._thrust_N if self.motor_tau_s > 0.0 else self.commanded_thrusts_N()

    def lift_factor(self) -> float:
        """Ground effect: total lift / total rotor thrust."""
        return 1.0 + self.thrust_ground_effect_gain * math.exp(-self.plant.z_m / 0.25)

    def _specific_force_B(self) -> tuple[float, float, float]:
        thrust = sum(self.thrusts_N()) * self.lift_factor()
        if self.plant.z_m <= 0.0 and thrust < self.M_KG * G:
            phi, theta = self.plant.euler_rad[0], self.plant.euler_rad[1]
            # at rest on the ground: f = -g_N in body axes
            return (G * math.sin(theta), -G * math.sin(phi) * math.cos(theta), -G * math.cos(phi) * math.cos(theta))
        return (0.0, 0.0, -thrust / self.M_KG)

    def _step_plant(self, dt: float) -> None:
        p = self.plant
        if self.motor_tau_s > 0.0:  # first-order motor lag, exact for the held command
            a = math.exp(-dt / self.motor_tau_s)
            self._thrust_N = [c + (f0 - c) * a for f0, c in zip(self._thrust_N, self.commanded_thrusts_N())]
        f = self.thrusts_N()
        lift = sum(f) * self.lift_factor()
        l = 0.25 / math.sqrt(2.0)
        xy = ((l, l, 1), (-l, -l, 1), (l, -l, -1), (-l, l, -1))
        tau = (sum(-y * fi for (x, y, s), fi in zip(xy, f)), sum(x * fi for (x, y, s), fi in zip(xy, f)),
               sum(self.KQ_OVER_KT_M * s * fi for (x, y, s), fi in zip(xy, f)))
        on_ground = p.z_m <= 0.0 and lift * math.cos(p.euler_rad[0]) * math.cos(p.euler_rad[1]) < self.M_KG * G
        for i in range(3):
            if on_ground and i < 2:
                p.omega_radps[i] = 0.0  # the legs keep it level on the ground
                continue
            p.omega_radps[i] += tau[i] / self.J[i] * dt
            p.euler_rad[i] += p.omega_radps[i] * dt
        az = lift * math.cos(p.euler_rad[0]) * math.cos(p.euler_rad[1]) / self.M_KG - G
        p.vz_mps += az * dt
        p.z_m += p.vz_mps * dt
        if p.z_m <= 0.0:
            p.z_m, p.vz_mps = 0.0, max(0.0, p.vz_mps)

    def _adc_code(self, channel: int) -> int:
        if channel == 0:
            wash_m = self.baro_ground_effect_m * sum(self.thrusts_N()) / (self.M_KG * G) * math.exp(-self.plant.z_m / 0.5)
            h = self.FIELD_ALT_M + self.plant.z_m - wash_m + self.baro_offset_m
            p_kpa = 101.325 * (1.0 - 2.25577e-5 * h) ** 5.25588
            v = 5.0 * (0.009 * p_kpa - 0.095) + self._baro_rng.normal(0.0, self.baro_noise_V)
            v_adc = 16.0 * (v - 3.928375) + self.rng.normal(0.0, 0.0005)
        else:
            # ADXL335 flat, component side up: sensor (X, Y, Z) = (x_B, -y_B, -z_B).
            f = self._specific_force_B()[channel - 1] * (1.0 if channel == 1 else -1.0)
            v_adc = (3.3 * (0.5 + 0.1 * f / G) + self.accel_zero_g_error_V[channel - 1]
                     + self.rng.normal(0.0, 0.0005))
        code = min(4095, max(0, int(math.floor(4096.0 * v_adc / 5.0))))
        return code ^ self.code_xor.pop(channel, 0)

    def _tick(self) -> None:
        """Advance to the next tick and emit its IMU sample (unless silenced or stalled)."""
        if not self.imu.measuring:
            return
        if self.imu_stalled_reads:
            self.imu_stalled_reads -= 1
            return
        if self.k >= 0:
            self._step_plant(TICK_NS * 1e-9)
        self.k += 1
        self.clock.advance(TICK_NS * 1e-9)
        t_ns = self.k * TICK_NS
        self.rc.advance(t_ns)
        self.trace.append((t_ns, self.plant.z_m, list(self.plant.euler_rad), list(self.esc.pulses_us)))
        if self.k in self.imu_silent_ticks:
            return
        p = self.plant
        euler_deg = tuple(math.degrees(a) for a in p.euler_rad)
        self.ports["imu"].feed(self.imu.sample(t_ns, euler_deg, tuple(p.omega_radps), self._specific_force_B()))
