"""The ADC chain behind real ptys: Bus Pirate with pyserial clients that follow
pyBusPirateLite's and flashrom's entry sequences, and the unmodified PyPI ``spidriver``
client against the SPIDriver emulator.

Handshakes as read in juhasch/pyBusPirateLite (BBIO_base.enter_bb, SPI) and flashrom
buspirate_spi.c (docs/protocols.md §7.1); the SPIDriver client is spidriver 1.1.1 from
PyPI, unmodified. Blocking calls run in threads; pyserial timeouts are failure guards or the
clients' own protocol (pyBusPirateLite polls with 0.1 s reads), never timing assertions.
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import numpy as np
import pytest
import serial
from spidriver import SPIDriver

from emulators.analog import AnalogFrontEnd, AnalogParams, Adxl335Params, Mpx5100apParams
from emulators.analog.inverse import pressure_Pa_from_code
from emulators.base import ByteDevice
from emulators.buspirate import BusPirate, BusPirateParams
from emulators.mcp3204 import Mcp3204, Mcp3204Conversion, Mcp3204Params, fig61_decode, fig61_request
from emulators.spidriver import SpiDriver, SpiDriverParams
from hil.transport import LineSettings, PtyPort

pytestmark = pytest.mark.pty

P_FIELD_PA = 100_000.0
REST = (0.0, 0.0, -9.80665)
#: The quiet default rig (no unit errors, no noise) at 100 kPa, level, at rest:
#: CH0 x16 stage -> 2.5 V + 16 * 0.045 * (100 - 101.325) V; CH1-3: 1.65, 1.65, 1.98 V.
CODES = [1266, 1351, 1351, 1622]


def quiet_chain() -> tuple[Mcp3204, AnalogFrontEnd]:
    accel = Adxl335Params(
        sensitivity_tolerance=0.0,
        zero_g_tolerance_V_at_3V=(0.0, 0.0, 0.0),
        zero_g_drift_mg_per_C=(0.0, 0.0, 0.0),
        cross_axis_fraction=0.0,
        noise_density_ug_per_rtHz_at_3V=(0.0, 0.0, 0.0),
    )
    base = AnalogParams(baro=Mpx5100apParams(unit_error_kPa=0.0, noise_V_rms=0.0), accel=accel)
    silent = tuple(dataclasses.replace(c, noise_V_rms=0.0) for c in base.conditioning)
    params = dataclasses.replace(base, conditioning=silent)  # type: ignore[arg-type]
    fe = AnalogFrontEnd(params, np.random.default_rng(0))
    fe.update(0, P_FIELD_PA, REST, 25.0)
    return Mcp3204(Mcp3204Params(), fe.volts), fe


@asynccontextmanager
async def bench_port(name: str, dev_dir: Path, device: ByteDevice) -> AsyncIterator[PtyPort]:
    """A pty whose client bytes go to ``device``; replies are written back at once."""
    port = PtyPort(name, dev_dir)

    def on_data(data: bytes, t_ns: int) -> None:
        device.receive(data, t_ns)
        out = device.take_output()
        if out:
            port.write(out)

    def on_line(settings: LineSettings) -> None:
        if settings.baud is not None:
            device.line_settings_changed(settings.baud, 0)

    port.on_data = on_data
    port.on_line = on_line
    await port.start()
    port.write(device.take_output())  # power-up output: the client's open flushes it
    try:
        yield port
    finally:
        port.close()


@pytest.fixture
def dev_dir(tmp_path: Path) -> Path:
    d = tmp_path / "dev"
    d.mkdir(mode=0o700)
    return d


def read_exactly(ser: serial.Serial, n: int) -> bytes:
    data = ser.read(n)
    assert len(data) == n, f"wanted {n} bytes, got {data!r}"
    return data


def wait_for(ser: serial.Serial, key: bytes) -> None:
    """flashrom's buspirate_wait_for_string: slide a window over single-byte reads."""
    window = read_exactly(ser, len(key))
    while window != key:
        window = window[1:] + read_exactly(ser, 1)


def read_word(ser: serial.Serial) -> str:
    """flashrom: read up to 18 bytes until whitespace."""
    word = bytearray()
    for _ in range(18):
        c = read_exactly(ser, 1)
        if c in b"\r\n\t ":
            break
        word += c
    return word.decode()


def pybuspiratelite_session(path: str) -> list[int]:
    """BBIO_base.enter_bb + SPI as pyBusPirateLite does it (timeout 0.1 s polling)."""
    ser = serial.Serial(path, 115200, timeout=0.1)
    try:
        ser.reset_input_buffer()
        for _ in range(10):
            ser.write(b"\x00")
            if ser.read(1):
                break
            ser.write(b"\x00\x00")
        ser.reset_input_buffer()
        ser.read(200)  # drain whatever came after the flush
        ser.write(b"\x00")
        assert ser.read(5) == b"BBIO1"
        ser.reset_input_buffer()
        ser.write(b"\x01")
        assert ser.read(4) == b"SPI1"
        ser.timeout = 5.0
        for cmd in (0x4C, 0x8A, 0x63):  # pins: power|pull-ups; config: push-pull|CKE; 1 MHz
            ser.write(bytes([cmd]))
            assert read_exactly(ser, 1) == b"\x01"
        codes = []
        for ch in range(4):
            ser.write(b"\x02")  # spi.cs = True
            assert read_exactly(ser, 1) == b"\x01"
            ser.write(bytes([0x10 + 3 - 1]) + fig61_request(ch))  # spi.transfer([...])
            reply = read_exactly(ser, 4)
            assert reply[0] == 1
            codes.append(fig61_decode(reply[1:]))
            ser.write(b"\x03")  # spi.cs = False
            assert read_exactly(ser, 1) == b"\x01"
        ser.write(b"\x00\x0f")  # back to BBIO, then hw_reset
        assert read_exactly(ser, 6) == b"BBIO1\x01"
        return codes
    finally:
        ser.close()


def flashrom_session(path: str) -> tuple[str, str, list[int]]:
    """buspirate_spi_init as flashrom does it, then MCP3204 reads on both command paths."""
    ser = serial.Serial(path, 115200, timeout=5.0)
    try:
        for _ in range(20):
            ser.write(b"\x00")
        wait_for(ser, b"BBIO")
        ser.write(b"\x0f")  # reset: parse the banner
        wait_for(ser, b"irate ")
        hardware = read_word(ser)
        wait_for(ser, b"irmware ")
        firmware = read_word(ser)
        wait_for(ser, b"HiZ>")
        for _ in range(20):
            ser.write(b"\x00")
        wait_for(ser, b"BBIO")
        assert read_exactly(ser, 1) == b"1"
        ser.write(b"\x01")
        wait_for(ser, b"SPI")
        assert read_exactly(ser, 1) == b"1"
        for cmd in (0x40 | 0x0B, 0x60 | 0x4, 0x80 | 0x0A, 0x03):  # 6.1: speed capped at 2 MHz
            ser.write(bytes([cmd]))
            assert read_exactly(ser, 1) == b"\x01"
        codes = []
        for ch in range(4):  # command set v2 (fw >= 5.5): write-then-read, 1 byte out, 2 in
            ser.write(bytes([0x04, 0, 1, 0, 2, 1 << 6 | 1 << 5 | ch << 2]))
            reply = read_exactly(ser, 3)
            assert reply[0] == 1
            codes.append(reply[1] << 4 | reply[2] >> 4)
        # command set v1 pipelines CS low, the bulk transfer and CS high in one write
        ser.write(bytes.fromhex("02 13 06 40 00 00 03"))
        reply = read_exactly(ser, 7)
        assert reply[:2] == b"\x01\x01" and reply[-1:] == b"\x01"
        codes.append(fig61_decode(reply[2:5]))
        return hardware, firmware, codes
    finally:
        ser.close()


async def test_buspirate_pybuspiratelite_style(dev_dir: Path) -> None:
    adc, _ = quiet_chain()
    bp = BusPirate(BusPirateParams(), adc)
    async with bench_port("adc", dev_dir, bp) as port:
        codes = await asyncio.to_thread(pybuspiratelite_session, port.path)
    assert codes == CODES
    assert bp.counters["bulk_transfers"] == 4 and bp.counters["protocol_errors"] == 0


async def test_buspirate_flashrom_style(dev_dir: Path) -> None:
    adc, fe = quiet_chain()
    bp = BusPirate(BusPirateParams(), adc)
    async with bench_port("adc", dev_dir, bp) as port:
        hardware, firmware, codes = await asyncio.to_thread(flashrom_session, port.path)
    assert (hardware, firmware) == ("v3.5", "v6.1")
    assert codes == CODES + [CODES[1]]
    events = [e for e in bp.take_events() if isinstance(e, Mcp3204Conversion)]
    assert [e.code for e in events] == codes
    assert abs(pressure_Pa_from_code(codes[0], fe.params) - P_FIELD_PA) <= 1.7


def spidriver_session(path: str) -> tuple[str, list[int]]:
    s = SPIDriver(path)  # 64 x '@', echo test, status: all unmodified client code
    try:
        codes = []
        for ch in range(4):
            s.sel()
            codes.append(fig61_decode(s.writeread(fig61_request(ch))))
            s.unsel()
        s.getstatus()
        assert s.cs == 1
        return s.product, codes
    finally:
        s.ser.close()


async def test_spidriver_pypi_client_unmodified(dev_dir: Path) -> None:
    adc, _ = quiet_chain()
    sd = SpiDriver(SpiDriverParams(), adc)
    async with bench_port("adc-spidriver", dev_dir, sd) as port:
        product, codes = await asyncio.to_thread(spidriver_session, port.path)
    assert product == "spidriver2"
    assert codes == CODES
    assert sd.host_baud == 460800 and sd.counters["bytes_at_wrong_baud"] == 0
    assert [e.code for e in sd.take_events() if isinstance(e, Mcp3204Conversion)] == CODES
