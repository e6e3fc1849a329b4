"""The XSENS emulator behind a real pty, driven by pyserial clients written like the real ones.

Clients (docs/protocols.md §1.12, read as specs, not copied):
* ethz-asl/ethzasl_xsens_driver ``mtdevice.py``: drain input before each write; GoToConfig
  -> ReqConfiguration (exactly 118 bytes, unpacked with the driver's layout) ->
  SetOutputConfiguration -> GoToMeasurement, then MTData2.
* Xsens XDA (xspublic scanner/device init + the ROS driver's configuration): GoToConfig,
  ReqDID, ReqProductCode, ReqHardwareVersion, ReqFWRev, InitMT, ReqConfiguration, ReqFWRev,
  ReqOutputConfiguration, ReqAvailableFilterProfiles, SetStringOutputType,
  SetOutputConfiguration, GoToMeasurement; then 400 Hz MTData2.
* ozymandium/lse-xsens-mti (legacy MTi): GoToConfig, SetOutputMode, SetOutputSettings,
  ReqOutputMode, ReqOutputSettings, GoToMeasurement; MTData decoded with the replies.

The glue plays the bench: client bytes go to ``receive`` at the glue's sim time (boot at
t < 0), replies are written back at once; streaming is lockstep (advance one tick, write,
wait until the client has read the sample). pyserial timeouts are failure guards only.
"""

from __future__ import annotations

import asyncio
import struct
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import serial

from emulators.base import DeviceEvent
from emulators.xsens import MtiDevice, SampleSent, State, XsensParams
from emulators.xsens.params import Identity
from hil.transport import LineSettings, PtyPort

pytestmark = pytest.mark.pty

TICK_NS = 2_500_000
BOOT_NS = -1_000_000_000
GUARD_S = 10.0  # failure guard for waits, never a timing assertion
Signal = Callable[[], None]


# -- the glue (the bench's role) --------------------------------------------------------------

class Glue:
    """Connects one MtiDevice to a PtyPort on a sim clock the test drives."""

    def __init__(self, device: MtiDevice, port: PtyPort) -> None:
        self.dev, self.port = device, port
        self.t_ns = BOOT_NS
        self.measuring = asyncio.Event()
        self.rx = asyncio.Event()
        self.read_acks: asyncio.Queue[int] = asyncio.Queue()
        self.events: list[DeviceEvent] = []
        self.loop = asyncio.get_running_loop()
        port.on_data = self._on_data
        port.on_line = self._on_line

    def _flush(self) -> list[DeviceEvent]:
        out = self.dev.take_output()
        if out:
            self.port.write(out)
        events = self.dev.take_events()
        self.events += events
        return events

    def _on_data(self, data: bytes, t_ns: int) -> None:
        self.dev.receive(data, self.t_ns)
        self._flush()
        self.rx.set()
        if self.dev.measuring:
            self.measuring.set()

    async def wait_rx(self, condition: Callable[[], bool]) -> None:
        """Wait (on received data, not on time) until ``condition`` holds."""
        while True:
            self.rx.clear()
            if condition():
                return
            await asyncio.wait_for(self.rx.wait(), GUARD_S)

    def _on_line(self, settings: LineSettings) -> None:
        if settings.baud is not None:
            self.dev.line_settings_changed(settings.baud, self.t_ns)

    def client_read_one(self) -> None:
        """Called from the client thread for every sample it has read."""
        self.loop.call_soon_threadsafe(self.read_acks.put_nowait, 1)

    async def stream(self, n_samples: int, step_ns: int = TICK_NS) -> None:
        """Lockstep: advance, write, wait until the client read what was sent."""
        await asyncio.wait_for(self.measuring.wait(), GUARD_S)
        self.t_ns = 0
        sent = 0
        while sent < n_samples:
            self.dev.advance(self.t_ns)
            k = sum(isinstance(e, SampleSent) for e in self._flush())
            for _ in range(k):
                await asyncio.wait_for(self.read_acks.get(), GUARD_S)
            sent += k
            self.t_ns += step_ns


@asynccontextmanager
async def imu_port(dev_dir: Path, device: MtiDevice) -> AsyncIterator[Glue]:
    port = PtyPort("imu", dev_dir)
    await port.start()
    glue = Glue(device, port)
    try:
        yield glue
    finally:
        port.close()


@pytest.fixture
def dev_dir(tmp_path: Path) -> Path:
    d = tmp_path / "dev"
    d.mkdir(mode=0o700)
    return d


def mk4_device(**kw: object) -> MtiDevice:
    return MtiDevice(XsensParams(**kw), np.random.default_rng(42))  # type: ignore[arg-type]


# -- client-side Xbus, written from the protocol description ------------------------------------

class XbusError(Exception):
    def __init__(self, code: int) -> None:
        super().__init__(f"device answered Error 0x{code:02X}")
        self.code = code


class XbusClient:
    """Blocking pyserial Xbus endpoint: framing, preamble search, checksum check."""

    def __init__(self, path: str, baud: int, timeout_s: float = 0.05) -> None:
        self.ser = serial.Serial(path, baud, timeout=timeout_s)
        self.bad_checksums = 0

    def close(self) -> None:
        self.ser.close()

    def write_msg(self, mid: int, data: bytes = b"") -> None:
        n = len(data)
        length = bytes((n,)) if n <= 254 else b"\xff" + struct.pack(">H", n)
        body = b"\xff" + bytes((mid,)) + length + data
        self.ser.write(b"\xfa" + body + bytes(((-sum(body)) & 0xFF,)))

    def _exactly(self, n: int) -> bytes:
        buf = bytearray()
        for _ in range(max(100, int(GUARD_S / (self.ser.timeout or 1.0)))):  # failure guard
            buf += self.ser.read(n - len(buf))
            if len(buf) == n:
                return bytes(buf)
        raise TimeoutError(f"waited for {n} bytes, got {bytes(buf)!r}")

    def read_msg(self) -> tuple[int, bytes]:
        """Next valid message; raises XbusError on an Error message."""
        while True:
            if self._exactly(1) != b"\xfa":
                continue
            if self._exactly(1) != b"\xff":
                continue
            mid, n = self._exactly(2)
            ext = b""
            if n == 0xFF:
                ext = self._exactly(2)
                n = struct.unpack(">H", ext)[0]
            rest = self._exactly(n + 1)
            if (0xFF + mid + (0xFF if ext else 0) + sum(ext) + (n if not ext else 0) + sum(rest)) & 0xFF:
                self.bad_checksums += 1
                continue
            if mid == 0x42:
                raise XbusError(rest[0])
            return mid, rest[:-1]

    def transact(self, mid: int, data: bytes = b"", ack: int | None = None, max_reads: int = 25) -> bytes:
        """Send, then read until the ack (MID + 1) arrives."""
        ack = mid + 1 if ack is None else ack
        self.write_msg(mid, data)
        for _ in range(max_reads):
            got, payload = self.read_msg()
            if got == ack:
                return payload
        raise AssertionError(f"no ack 0x{ack:02X} to 0x{mid:02X}")


def decode_mtdata2(payload: bytes) -> dict[int, bytes]:
    items, i = {}, 0
    while i < len(payload):
        xdi, size = struct.unpack_from(">HB", payload, i)
        items[xdi] = payload[i + 3 : i + 3 + size]
        i += 3 + size
    assert i == len(payload)
    return items


FLIGHT_CONFIG = ((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400), (0xE020, 0xFFFF))


def encode_config(entries: tuple[tuple[int, int], ...]) -> bytes:
    return b"".join(struct.pack(">HH", x, f) for x, f in entries)


# -- (a) ethz-style Python driver ----------------------------------------------------------------

def ethz_style_session(path: str, n_samples: int, signal: Signal) -> dict[str, Any]:
    c = XbusClient(path, 921_600, timeout_s=0.002)  # the driver's default timeout
    try:
        c.ser.reset_input_buffer()
        c.ser.reset_output_buffer()

        def write_ack(mid: int, data: bytes = b"") -> bytes:
            for _ in range(30):  # n_resend
                while c.ser.read():  # ethz drains input before every write
                    pass
                c.write_msg(mid, data)
                for _ in range(25):  # n_read
                    got, payload = c.read_msg()
                    if got == mid + 1:
                        return payload
            raise AssertionError(f"Ack (0x{mid + 1:02X}) expected")

        write_ack(0x30)  # GoToConfig
        config = write_ack(0x0C)  # ReqConfiguration
        master, period, skip, _, _, _, date, time_, num, did, length, mode, settings_ = struct.unpack(
            "!IHHHHI8s8s32x32xHIHHI8x", config)  # raises unless exactly 118 bytes
        applied = write_ack(0xC0, encode_config(FLIGHT_CONFIG))
        write_ack(0x10)  # GoToMeasurement
        samples: list[Any] = []
        while len(samples) < n_samples:
            mid, payload = c.read_msg()
            assert mid == 0x36, f"unknown data message: mid=0x{mid:02X}"  # ethz raises here too
            items = decode_mtdata2(payload)
            samples.append((struct.unpack(">H", items[0x1020])[0], struct.unpack(">I", items[0x1060])[0],
                            struct.unpack(">3f", items[0x2034])))
            signal()
        return {"device_id": did, "master": master, "period": period, "num": num, "length": length,
                "mode": mode, "settings": settings_, "applied": applied, "samples": samples,
                "bad_checksums": c.bad_checksums}
    finally:
        c.close()


async def test_ethz_style_handshake_and_stream(dev_dir: Path) -> None:
    dev = mk4_device()
    async with imu_port(dev_dir, dev) as glue:
        client = asyncio.to_thread(ethz_style_session, glue.port.path, 40, glue.client_read_one)
        result, _ = await asyncio.gather(client, glue.stream(40))
    assert result["device_id"] == result["master"] == 0x037003F8 and result["num"] == 1
    assert (result["period"], result["length"], result["mode"], result["settings"]) == (1152, 0, 0, 1)
    assert result["applied"] == encode_config(FLIGHT_CONFIG)
    samples = result["samples"]
    assert [s[0] for s in samples] == list(range(40))
    assert [s[1] for s in samples] == [25 * k for k in range(40)]
    assert result["bad_checksums"] == 0
    assert dev.host_baud == 921_600 and dev.counters["errors_sent"] == 0


# -- (b) XDA (vendor SDK) scan + device init + ROS driver configuration --------------------------

def xda_style_session(path: str, n_samples: int, signal: Signal) -> dict[str, Any]:
    c = XbusClient(path, 921_600)
    try:
        c.transact(0x30)  # GoToConfig (scan)
        did = c.transact(0x00)  # ReqDID: 4 or 8 bytes
        product = c.transact(0x1C).split(b" ")[0].decode()  # XDA cuts at the first space
        hw = c.transact(0x1E)
        fw = c.transact(0x12)
        assert len(fw) >= 3
        c.transact(0x30)  # XsControl::openPort -> device init
        init = c.transact(0x02)  # InitMT -> InitMTResults, 4-byte id
        config = c.transact(0x0C)
        fw2 = c.transact(0x12)
        current = c.transact(0xC0)  # ReqOutputConfiguration
        profiles = c.transact(0x62)
        labels = [profiles[i + 2 : i + 22].rstrip(b" ").decode() for i in range(0, len(profiles), 22)]
        assert c.transact(0x8E, b"\x00\x00") == b""  # SetStringOutputType 0 (non-600 devices)
        applied = c.transact(0xC0, encode_config(FLIGHT_CONFIG))
        c.transact(0x10)  # GoToMeasurement
        counters: list[int] = []
        stf: list[int] = []
        raw_checksums_ok = 0
        while len(counters) < n_samples:
            mid, payload = c.read_msg()
            assert mid == 0x36
            raw_checksums_ok += 1
            items = decode_mtdata2(payload)
            counters.append(struct.unpack(">H", items[0x1020])[0])
            stf.append(struct.unpack(">I", items[0x1060])[0])
            signal()
        return {"did": did, "product": product, "hw": hw, "fw": fw, "fw2": fw2, "init": init,
                "config_len": len(config), "current": current, "labels": labels, "applied": applied,
                "counters": counters, "stf": stf, "frames": raw_checksums_ok, "bad": c.bad_checksums}
    finally:
        c.close()


async def test_xda_style_scan_init_and_400_samples_at_400_hz(dev_dir: Path) -> None:
    dev = mk4_device()
    n = 480
    async with imu_port(dev_dir, dev) as glue:
        client = asyncio.to_thread(xda_style_session, glue.port.path, n, glue.client_read_one)
        result, _ = await asyncio.gather(client, glue.stream(n))
    assert result["did"] == result["init"] == bytes.fromhex("037003F8")
    assert result["product"] == "MTi-300-2A5G4" and result["hw"] == b"\x02\x00"
    assert result["fw"] == result["fw2"] == bytes.fromhex("01 08 02 00 00 00 25 00 01 15 34")
    assert result["config_len"] == 118
    assert result["current"] == encode_config(((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2010, 100), (0xE020, 0xFFFF)))
    assert result["labels"] == ["general", "high_mag_dep", "dynamic", "low_mag_dep", "vru_general"]
    assert result["applied"] == encode_config(FLIGHT_CONFIG)
    counters, stf = result["counters"], result["stf"]
    assert result["frames"] == n and result["bad"] == 0
    assert all((b - a) & 0xFFFF == 1 for a, b in zip(counters, counters[1:], strict=False))
    assert all((b - a) & 0xFFFF_FFFF == 25 for a, b in zip(stf, stf[1:], strict=False))
    assert dev.counters["samples_sent"] == n and dev.counters["overruns"] == 0


# -- (c) legacy MTi, ozymandium/lse-xsens-mti sequence --------------------------------------------

LEGACY_MODE = 0x0006  # calibrated + orientation
LEGACY_SETTINGS = 0x0000_0005  # sample counter, Euler


def ozymandium_style_session(path: str, n_samples: int, signal: Signal) -> dict[str, Any]:
    c = XbusClient(path, 921_600)
    try:
        c.transact(0x30)
        assert c.transact(0xD0, struct.pack(">H", LEGACY_MODE)) == b""
        assert c.transact(0xD2, struct.pack(">I", LEGACY_SETTINGS)) == b""
        mode = struct.unpack(">H", c.transact(0xD0))[0]  # the decoder uses these replies
        settings_ = struct.unpack(">I", c.transact(0xD2))[0]
        c.transact(0x10)
        n_floats = (9 if mode & 0x2 else 0) + (3 if mode & 0x4 else 0)
        samples: list[Any] = []
        while len(samples) < n_samples:
            mid, payload = c.read_msg()
            assert mid == 0x32 and len(payload) == 4 * n_floats + 2
            floats = struct.unpack(f">{n_floats}f", payload[: 4 * n_floats])
            samples.append((struct.unpack(">H", payload[-2:])[0], floats[9:12], floats[0:3]))
            signal()
        return {"mode": mode, "settings": settings_, "samples": samples}
    finally:
        c.close()


async def test_legacy_mti_ozymandium_style(dev_dir: Path) -> None:
    dev = MtiDevice(XsensParams(identity=Identity.LEGACY, orientation_noise_deg=0.0, orientation_bias_rp_deg=0.0,
                                orientation_bias_yaw_deg=0.0), np.random.default_rng(3))
    async with imu_port(dev_dir, dev) as glue:
        client = asyncio.to_thread(ozymandium_style_session, glue.port.path, 30, glue.client_read_one)
        result, _ = await asyncio.gather(client, glue.stream(30))
    assert (result["mode"], result["settings"]) == (LEGACY_MODE, LEGACY_SETTINGS)
    samples = result["samples"]
    assert [s[0] for s in samples] == list(range(30))  # default period 1152: 100 Hz
    assert all(s[1] == pytest.approx((0.0, 0.0, 0.0), abs=1e-9) for s in samples)  # level, north, NWU
    assert all(s[2][2] == pytest.approx(9.80665, abs=0.3) for s in samples)  # z up in the legacy frame
    assert dev.state is State.MEASUREMENT and dev.counters["unknown_mids"] == 0


# -- bad input over the wire ---------------------------------------------------------------------

def garbage_session(path: str) -> dict[str, Any]:
    c = XbusClient(path, 921_600)
    try:
        c.transact(0x30)
        c.ser.write(bytes(range(0x00, 0xFA)))  # random-ish garbage without a preamble
        c.ser.write(b"\xfa\xff\x30\x00\x00")  # corrupted GoToConfig (bad checksum)
        errors = []
        for mid in (0x06, 0x0A):  # unknown MID; ReqDataLength (not on mk4)
            try:
                c.transact(mid)
            except XbusError as exc:
                errors.append(exc.code)
        did = c.transact(0x00)
        return {"errors": errors, "did": did}
    finally:
        c.close()


async def test_garbage_and_unsupported_messages_over_the_pty(dev_dir: Path) -> None:
    dev = mk4_device()
    async with imu_port(dev_dir, dev) as glue:
        result = await asyncio.to_thread(garbage_session, glue.port.path)
    assert result == {"errors": [0x04, 0x04], "did": bytes.fromhex("037003F8")}
    assert dev.counters["checksum_errors"] == 1 and dev.counters["resync_bytes"] >= 0xFA
    assert dev.counters["unknown_mids"] == 2 and dev.state is State.CONFIG


def wrong_baud_session(path: str, n_bytes: Callable[[], int]) -> tuple[bytes, int]:
    c = XbusClient(path, 115_200)
    try:
        c.write_msg(0x30)
        # Read exactly what the device wrote meanwhile (the glue tells how much).
        return c._exactly(n_bytes()), c.bad_checksums
    finally:
        c.close()


async def test_client_at_the_wrong_baud_sees_garbage_and_is_not_understood(dev_dir: Path) -> None:
    dev = mk4_device()  # 921600
    async with imu_port(dev_dir, dev) as glue:
        loop = asyncio.get_running_loop()
        written: asyncio.Future[int] = loop.create_future()

        async def produce() -> None:
            # Wait until the device has seen the client's GoToConfig bytes (at the wrong rate).
            await glue.wait_rx(lambda: dev.counters["rx_wrong_baud_bytes"] >= 5)
            glue.t_ns = 0
            dev.advance(50_000_000)  # six 100 Hz samples, garbled on the way
            before = glue.port.stats.bytes_tx
            glue._flush()
            written.set_result(glue.port.stats.bytes_tx - before)

        async def get_written() -> int:
            return await written

        def n_bytes() -> int:
            return asyncio.run_coroutine_threadsafe(get_written(), loop).result(GUARD_S)

        client = asyncio.to_thread(wrong_baud_session, glue.port.path, n_bytes)
        (data, _), _ = await asyncio.gather(client, produce())
    assert dev.state is State.MEASUREMENT  # the GoToConfig at 115200 was not understood
    assert dev.host_baud == 115_200 and dev.counters["host_baud_mismatch"] == 1
    assert 0 < len(data) < dev.counters["tx_bytes"]  # fewer characters than the device sent
    assert b"\xfa\xff\x36" not in data
