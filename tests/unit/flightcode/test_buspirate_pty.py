"""The flight code's Bus Pirate driver on a real pyserial port over a real pty, against the
real Bus Pirate + MCP3204 emulators, with some replies held back far past the read timeout."""

from __future__ import annotations

import asyncio
import io
from pathlib import Path

import pytest
import serial

from emulators.buspirate import BusPirate, BusPirateParams
from emulators.mcp3204 import Mcp3204, Mcp3204Params
from flightcode.drivers.buspirate_spi import BusPirateSpi
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.log import Logger
from hil.transport.pty import PtyPort
from tests.unit.flightcode.emulated_buspirate import TICK_NS, expected_codes

HELD = {5: 0.3, 12: 0.3, 13: 0.05, 30: 0.3}  # transfer number -> extra delay of its reply, s


@pytest.mark.pty
async def test_late_replies_over_a_pty_are_never_data_and_need_no_resync(tmp_path: Path) -> None:
    dev_dir = tmp_path / "dev"
    dev_dir.mkdir(mode=0o700)
    port = PtyPort("adc", dev_dir)
    await port.start()
    sample = {"t_ns": 0}
    device = BusPirate(BusPirateParams(), Mcp3204(Mcp3204Params(),
                                                  lambda ch, t_ns: (expected_codes(t_ns)[ch] + 0.5) * 5.0 / 4096))
    device.take_output()  # the power-up banner
    loop = asyncio.get_running_loop()
    transfers = {"n": 0}
    released = asyncio.Event()

    def answer(data: bytes, t_ns: int) -> None:
        device.receive(data, sample["t_ns"])
        out = device.take_output()
        if len(data) == 28:  # one sample's pipelined conversions
            n = transfers["n"] = transfers["n"] + 1
            if n in HELD:
                def release(out: bytes = out, last: bool = n == max(HELD)) -> None:
                    port.write(out)
                    if last:
                        released.set()

                loop.call_later(HELD[n], release)
                return
        if out:
            port.write(out)

    port.on_data = answer
    ser = serial.Serial(port.path, 115200, timeout=0.02, exclusive=True)
    try:
        bridge = BusPirateSpi(ser, speed_hz=1_000_000, entry_attempts=3, reply_timeout_s=2.0, quiet_s=0.03,
                              resync_interval_ns=250_000_000, log=Logger(io.StringIO()))
        await asyncio.to_thread(bridge.enter_spi)
        reader = Mcp3204Reader(bridge, (0, 1, 2, 3))
        k = 0
        while not (released.is_set() and bridge.in_sync and transfers["n"] > max(HELD) + 5):
            sample["t_ns"] = k * TICK_NS
            codes = await asyncio.to_thread(reader.read_codes, sample["t_ns"])
            assert codes is None or codes == expected_codes(sample["t_ns"]), f"sample {k} misread {dict(device.counters)}"
            k += 1
            assert k < 100_000
        c = bridge.counters
        assert c["late_replies"] >= 3 and c["resyncs"] == 0 and c["bad_ack"] == 0
        assert c["late_replies_discarded"] == c["late_replies"]
        assert reader.counters["failed_reads"] == c["late_replies"]  # each cost its own sample
        assert reader.counters["reads"] == transfers["n"] - c["late_replies"]
    finally:
        ser.close()
        port.close()
