"""A host switches the emulated Bus Pirate to 1 Mbaud with the terminal's ``b`` menu over a
real pty, then changes its own termios (in place, or by reopening at the new speed): the
bench follows the change (TIOCPKT/EXTPROC notifications) and the session goes on at the new
rate, into binary mode as flashrom would."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
import serial

from emulators.buspirate import BusPirate, BusPirateParams
from emulators.mcp3204 import Mcp3204, Mcp3204Params
from tests.pty.test_adc_pty import bench_port

pytestmark = pytest.mark.pty

CONFIRM = b"Adjust your terminal\r\nSpace to continue\r\n"


def _until(ser: serial.Serial, marker: bytes) -> bytes:
    got = ser.read_until(marker)
    assert got.endswith(marker), got
    return got


@pytest.mark.parametrize("how", ["in place", "reopen"])
async def test_host_follows_the_b_menu_to_one_mbaud(how: str, tmp_path: Path) -> None:
    bp = BusPirate(BusPirateParams(), Mcp3204(Mcp3204Params(), lambda ch, t: 1.0))
    async with bench_port("adc", tmp_path, bp) as port:

        def host() -> bytes:
            ser = serial.Serial(port.path, 115200, timeout=2.0)
            try:
                ser.write(b"\r")
                _until(ser, b"HiZ>")
                ser.write(b"b\r")
                _until(ser, b"\r\n(9)>")
                ser.write(b"10\r")
                _until(ser, b"\r\n(34)>")
                ser.write(b"3\r")
                assert _until(ser, CONFIRM).endswith(b"3\r\n" + CONFIRM)
                if how == "in place":
                    ser.baudrate = 1_000_000
                else:
                    ser.close()
                    ser = serial.Serial(port.path, 1_000_000, timeout=2.0)
                ser.write(b" ")
                prompt = _until(ser, b"HiZ>")
                ser.write(b"\x00" * 20)
                bbio = ser.read(5)
                ser.write(b"\x01")
                return prompt + b"|" + bbio + ser.read(4)
            finally:
                ser.close()

        out = await asyncio.to_thread(host)
    assert out == b"HiZ>|BBIO1SPI1"
    assert bp.uart_baud_bps == 1_000_000 and bp.host_baud == 1_000_000
    assert port.stats.line_changes + port.stats.opens >= 2
    assert bp.counters["bytes_at_wrong_baud"] == 0
