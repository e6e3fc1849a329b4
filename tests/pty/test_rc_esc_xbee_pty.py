"""RC, Maestro/ESC and XBee emulators behind real ptys, with real pyserial clients and the
unmodified PyPI ``digi-xbee`` client.

Blocking client calls run in threads (``asyncio.to_thread``); pyserial read timeouts are
failure guards only, never timing assertions. Sim time either advances in explicit steps
(RC, Maestro) or, for digi-xbee which waits on wall time, follows the event-loop clock.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path

import numpy as np
import pytest
import serial

from emulators.base import ByteDevice
from emulators.esc import Esc, EscParams
from emulators.maestro import (
    Maestro,
    MaestroParams,
    TargetsSet,
    get_position,
    set_multiple_targets,
)
from emulators.rc import (
    CaptureFrontEnd,
    CaptureParams,
    PpmGenerator,
    PpmParams,
    SbusConverter,
    SbusParams,
    Setpoint,
    StickScript,
    raw_to_pwm,
    unpack_record,
    unpack_sbus,
)
from emulators.xbee import (
    ApiParser,
    LinkParams,
    RadioLink,
    XBeeModule,
    XBeeParams,
    encode_frame,
    tx16,
)
from hil.transport import PtyPort

pytestmark = pytest.mark.pty

MS = 1_000_000
TICK_NS = 2_500_000


@asynccontextmanager
async def bench_port(name: str, dev_dir: Path, device: ByteDevice,
                     clock: Callable[[], int]) -> AsyncIterator[PtyPort]:
    """A pty whose client bytes go to ``device``; its replies are written back at once."""
    port = PtyPort(name, dev_dir)
    port.sim_time = clock

    def on_data(data: bytes, t_ns: int) -> None:
        device.receive(data, t_ns)
        out = device.take_output()
        if out:
            port.write(out)

    def on_line(settings) -> None:  # type: ignore[no-untyped-def]
        if settings.baud is not None:
            device.line_settings_changed(settings.baud, clock())

    port.on_data = on_data
    port.on_line = on_line
    await port.start()
    try:
        yield port
    finally:
        port.close()


@pytest.fixture
def dev_dir(tmp_path: Path) -> Path:
    d = tmp_path / "dev"
    d.mkdir(mode=0o700)
    return d


async def open_serial(path: str, baud: int) -> serial.Serial:
    return await asyncio.to_thread(serial.Serial, path, baud, timeout=5.0)


async def read_exactly(ser: serial.Serial, n: int) -> bytes:
    data = await asyncio.to_thread(ser.read, n)
    assert len(data) == n, f"wanted {n} bytes, got {len(data)}"
    return data


# -- Maestro + ESCs -------------------------------------------------------------------------------
async def test_maestro_set_and_get_positions_then_escs_arm(dev_dir: Path) -> None:
    maestro = Maestro(MaestroParams())
    now = {"t": 0}
    async with bench_port("esc", dev_dir, maestro, lambda: now["t"]) as port:
        ser = await open_serial(port.path, 115200)
        try:
            # Four motors low (1000 us = 4000 qus) as one Set Multiple Targets.
            await asyncio.to_thread(ser.write, set_multiple_targets(0, [4000] * 4))
            await asyncio.to_thread(ser.write, b"".join(get_position(c) for c in range(4)))
            reply = await read_exactly(ser, 8)
            assert [int.from_bytes(reply[i:i + 2], "little") for i in range(0, 8, 2)] == [4000] * 4
            events = [e for e in maestro.take_events() if isinstance(e, TargetsSet)]
            assert events == [TargetsSet(0, 0, (4000,) * 4)]

            # ESCs behind the Maestro, stepped in sim time: low for 0.6 s arms them.
            escs = [Esc(EscParams(), np.random.default_rng(i)) for i in range(4)]
            for k in range(241):
                now["t"] = k * TICK_NS
                for i, esc in enumerate(escs):
                    esc.update(now["t"], maestro.pulse_us(i, now["t"]))
            assert all(esc.armed for esc in escs)

            # Half throttle on motor 2 over the wire (Pololu protocol form), read back.
            await asyncio.to_thread(ser.write, bytes.fromhex("AA 0C 04 02 70 2E") + bytes.fromhex("AA 0C 10 02"))
            assert await read_exactly(ser, 2) == bytes([0x70, 0x17])
            for k in range(241, 250):
                now["t"] = k * TICK_NS
                th = [esc.update(now["t"], maestro.pulse_us(i, now["t"])) for i, esc in enumerate(escs)]
            assert th[2] == pytest.approx((1500 - 1030) / 970) and th[0] == 0.0
        finally:
            ser.close()


# -- RC -----------------------------------------------------------------------------------------
SCRIPT = StickScript([Setpoint(0.0, 1, 1250), Setpoint(0.0, 2, 1750), Setpoint(0.0, 3, 1100),
                      Setpoint(0.0, 4, 1900)])
WANT_US = [1250, 1750, 1100, 1900, 1000, 1000, 1000, 1000]


def decode_capture_stream(data: bytes) -> list[list[int]]:
    """Reference reader of docs/rc-capture-format.md: resync, falling-edge widths, frames."""
    recs, i = [], 0
    while i + 6 <= len(data):
        if data[i] != 0xA5 or (rec := unpack_record(data[i:i + 6])) is None:
            i += 1
            continue
        recs.append(rec)
        i += 6
    frames: list[list[int]] = []
    cur: list[int] | None = None
    prev = None
    for r in recs:
        if r.level:
            continue
        if prev is not None:
            w = (r.capture_us - prev.capture_us) & 0xFFFF
            if w >= 2700:
                if cur is not None:
                    frames.append(cur)
                cur = []
            elif cur is not None:
                cur.append(w)
        prev = r
    return frames


async def test_rc_capture_records_over_pty(dev_dir: Path) -> None:
    gen = PpmGenerator(PpmParams(), np.random.default_rng(1), SCRIPT)
    fe = CaptureFrontEnd(CaptureParams())
    async with bench_port("rc", dev_dir, fe, lambda: 0) as port:
        ser = await open_serial(port.path, 115200)
        try:
            total = 0
            for k in range(81):  # 200 ms of sim time in 2.5 ms ticks
                t = k * TICK_NS
                fe.feed_edges(gen.edges_until(t))
                fe.advance(t)
                out = fe.take_output()
                if out:
                    assert await port.write_confirmed(out, timeout_s=5.0)
                    total += len(out)
            data = await read_exactly(ser, total)
        finally:
            ser.close()
    frames = decode_capture_stream(data)
    assert len(frames) >= 7
    for f in frames:
        assert len(f) == 8 and all(abs(a - b) <= 5 for a, b in zip(f, WANT_US))
    assert fe.counters["baud_mismatch"] == 0


async def test_rc_sbus_frames_over_pty(dev_dir: Path) -> None:
    gen = PpmGenerator(PpmParams(), np.random.default_rng(1), SCRIPT)
    conv = SbusConverter(SbusParams())
    async with bench_port("rc", dev_dir, conv, lambda: 0) as port:
        ser = await open_serial(port.path, 100000)
        try:
            chunks = bytearray()
            for k in range(121):  # 300 ms
                t = k * TICK_NS
                conv.feed_edges(gen.edges_until(t))
                conv.advance(t)
                out = conv.take_output()
                if out:
                    port.write(out)
                    chunks += out
            data = await read_exactly(ser, len(chunks))
        finally:
            ser.close()
    assert data == bytes(chunks) and len(data) == 25 * 22  # frames at 0, 14, ..., 294 ms
    frames = [unpack_sbus(data[i:i + 25]) for i in range(0, len(data), 25)]
    good = [f for f in frames if f is not None and not f.failsafe]
    assert len(good) >= 18
    for f in good:
        assert all(abs(raw_to_pwm(r) - w) <= 4.5 for r, w in zip(f.channels_raw, WANT_US))


# -- XBee ---------------------------------------------------------------------------------------
VEHICLE = XBeeParams()
GROUND = XBeeParams(my=0x0000, dl=0x0001, sl=0x40A1B202, ni="GROUND", ce=1)


@asynccontextmanager
async def xbee_bench(dev_dir: Path, vehicle_params: XBeeParams = VEHICLE,
                     ) -> AsyncIterator[tuple[PtyPort, PtyPort, XBeeModule, XBeeModule]]:
    """Both modules on ptys; a task advances sim time from the loop clock and moves packets."""
    loop = asyncio.get_running_loop()
    t0 = loop.time()

    def clock() -> int:
        return int((loop.time() - t0) * 1e9)

    vehicle = XBeeModule(vehicle_params, np.random.default_rng(1), "telemetry")
    ground = XBeeModule(GROUND, np.random.default_rng(2), "ground")
    link = RadioLink(LinkParams(), np.random.default_rng(3))
    link.attach(vehicle)
    link.attach(ground)
    stop = asyncio.Event()
    async with bench_port("telemetry", dev_dir, vehicle, clock) as vport, \
            bench_port("ground", dev_dir, ground, clock) as gport:

        async def pump() -> None:
            while not stop.is_set():
                t = clock()
                for m in (vehicle, ground):
                    m.advance(t)
                link.advance(t)
                for m, p in ((vehicle, vport), (ground, gport)):
                    out = m.take_output()
                    if out:
                        p.write(out)
                await asyncio.sleep(0.001)  # pacing of the sim clock, not a readiness wait

        task = asyncio.create_task(pump())
        try:
            yield vport, gport, vehicle, ground
        finally:
            stop.set()
            await task


async def test_xbee_vehicle_to_ground_pyserial(dev_dir: Path) -> None:
    async with xbee_bench(dev_dir) as (vport, gport, vehicle, ground):
        vser = await open_serial(vport.path, 115200)
        gser = await open_serial(gport.path, 115200)
        try:
            payloads = [f"att {k:03d} roll=+0.01".encode() for k in range(5)]
            for k, p in enumerate(payloads):
                await asyncio.to_thread(vser.write, encode_frame(tx16(k + 1, 0x0000, p)))
            rx_len = sum(len(encode_frame(bytes(5) + p)) for p in payloads)
            rx = ApiParser().feed(await read_exactly(gser, rx_len))
            assert [f[0] for f in rx] == [0x81] * 5
            assert [f[5:] for f in rx] == payloads
            assert all(f[1:3] == b"\x00\x01" and f[3] == 40 for f in rx)
            status = ApiParser().feed(await read_exactly(vser, 5 * 7))
            assert status == [bytes([0x89, k + 1, 0]) for k in range(5)]
        finally:
            vser.close()
            gser.close()


async def test_digi_xbee_ground_station_receives_vehicle_packets(dev_dir: Path) -> None:
    """digi-xbee opens the ground port unmodified (AP, HV, VR, SH, SL, NI, MY, CE queries)
    and receives the vehicle's TX16 packets.

    The vehicle module uses 64-bit source addressing (MY=0xFFFE), so the ground station
    gets RX64 frames: digi-xbee 1.5.0 looks up the 64-bit address of a 16-bit-only sender
    with blocking remote AT commands inside its reader thread, which stalls the reader for
    the remote's sync timeout (4 s) on every such packet, even though the emulated vehicle
    module answers the remote AT request (unit-tested in tests/unit/xbee).
    """
    from digi.xbee.devices import RemoteRaw802Device, XBeeDevice
    from digi.xbee.models.address import XBee64BitAddress
    from digi.xbee.models.protocol import XBeeProtocol

    async with xbee_bench(dev_dir, XBeeParams(my=0xFFFE)) as (vport, gport, vehicle, ground):
        device = XBeeDevice(gport.path, 115200)
        await asyncio.to_thread(device.open)
        vser = await open_serial(vport.path, 115200)
        try:
            assert device.get_protocol() == XBeeProtocol.RAW_802_15_4
            assert device.get_node_id() == "GROUND"
            assert device.get_16bit_addr().address == bytearray(b"\x00\x00")
            assert str(device.get_64bit_addr()) == "0013A20040A1B202"
            payloads = [f"telemetry {k}".encode() for k in range(3)]
            for k, p in enumerate(payloads):
                await asyncio.to_thread(vser.write, encode_frame(tx16(k + 1, 0x0000, p)))
            got = []
            for _ in payloads:
                msg = await asyncio.to_thread(device.read_data, 5)
                assert msg is not None
                got.append(bytes(msg.data))
                assert str(msg.remote_device.get_64bit_addr()) == "0013A20040A1B201"
            assert got == payloads
            status = ApiParser().feed(await read_exactly(vser, 3 * 7))
            assert status == [bytes([0x89, k + 1, 0]) for k in range(3)]
            # And back: send_data to the vehicle's 64-bit address (a TX64 frame); it waits for
            # the 0x89 status and raises unless it reports success.
            remote = RemoteRaw802Device(device, x64bit_addr=XBee64BitAddress.from_hex_string("0013A20040A1B201"))
            await asyncio.to_thread(device.send_data, remote, b"uplink")
            frames = ApiParser().feed(await read_exactly(vser, len(encode_frame(bytes(5) + b"uplink"))))
            assert frames[0][0] == 0x81 and frames[0][1:3] == b"\x00\x00" and frames[0][5:] == b"uplink"
        finally:
            vser.close()
            await asyncio.to_thread(device.close)
    assert ground.counters["at_api"] >= 8  # AP HV VR SH SL NI MY CE
