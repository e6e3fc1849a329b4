"""``hil devices``: every emulated device answers a real pyserial client on its pty."""

from __future__ import annotations

import asyncio
import io

import pytest
import serial
from rich.console import Console

from hil.flight.devices_live import serve_devices
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario

pytestmark = [pytest.mark.pty]


def _xbus(mid: int, payload: bytes = b"") -> bytes:
    body = bytes([0xFF, mid, len(payload)]) + payload
    return b"\xfa" + body + bytes([(-sum(body)) & 0xFF])


def _api(frame_data: bytes) -> bytes:
    return b"\x7e" + len(frame_data).to_bytes(2, "big") + frame_data + bytes([0xFF - (sum(frame_data) & 0xFF)])


async def test_devices_answer_real_clients() -> None:
    rig = load_rig(None)
    scenario = load_scenario(rig.scenario_path("hover"))
    paths: dict[str, str] = {}
    ready = asyncio.Event()

    def on_ready(p: dict[str, str]) -> None:
        paths.update(p)
        ready.set()

    console = Console(file=io.StringIO())
    server = asyncio.create_task(serve_devices(rig, scenario, seed=1, duration_s=None, console=console, on_ready=on_ready))
    try:
        await asyncio.wait_for(ready.wait(), 30)
        assert set(paths) == {"imu", "adc", "adc-spidriver", "rc", "esc", "telemetry", "ground"}
        printed = console.file.getvalue()  # type: ignore[attr-defined]
        assert all(path in printed for path in paths.values()), printed

        def imu_client() -> bytes:
            with serial.Serial(paths["imu"], rig.imu.baud_bps, timeout=0.5) as ser:
                ser.write(_xbus(0x30))  # GoToConfig
                ack = ser.read_until(_xbus(0x31))
                ser.write(_xbus(0x10))  # GoToMeasurement
                ser.read_until(_xbus(0x11))
                return ack + ser.read(300)  # the stream follows in real time

        imu = await asyncio.to_thread(imu_client)
        assert _xbus(0x31) in imu
        assert imu.count(b"\xfa\xff\x36") >= 2 or imu.count(b"\xfa\xff\x32") >= 2

        def esc_client() -> bytes:
            with serial.Serial(paths["esc"], rig.esc.maestro.baud, timeout=1.0) as ser:
                ser.write(bytes([0x84, 0x01, 0x70, 0x2E]))  # Set Target ch1 = 1500 us (6000 qus)
                ser.write(bytes([0x90, 0x01]))  # Get Position ch1
                return ser.read(2)

        pos = await asyncio.to_thread(esc_client)
        assert int.from_bytes(pos, "little") == 6000

        def telemetry_roundtrip() -> bytes:
            with serial.Serial(paths["ground"], 115200, timeout=2.0) as ground, serial.Serial(
                paths["telemetry"], 115200, timeout=1.0
            ) as vehicle:
                vehicle.write(_api(bytes([0x01, 0x00, 0x00, 0x00, 0x00]) + b"hello"))  # TX16 to 0x0000, no status
                return ground.read(14)

        rx = await asyncio.to_thread(telemetry_roundtrip)
        assert rx[3] == 0x81 and rx.endswith(b"hello" + rx[-1:]) and b"hello" in rx
    finally:
        server.cancel()
        counters = await asyncio.gather(server, return_exceptions=True)
    assert isinstance(counters[0], dict)
