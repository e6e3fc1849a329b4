"""``hil run --gdb``: a debugger on the emulated LPC2148's core (docs/board.md, "A debugger").

A client of GDB's remote protocol holds the core at reset, stops it at a breakpoint in the
firmware's loop, reads registers and memory, steps, interrupts it and detaches: the flight
then completes, and its plant truth is that of the same flight with no debugger (sim time does
not move while the debugger holds the core). ``kill`` ends the run with its log finalized.
GDB itself (gdb-multiarch, installed with the firmware's toolchain) stops at a breakpoint by
the firmware's symbol and shows the backtrace."""

from __future__ import annotations

import asyncio
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil.board import rsp
from hil.config import ConfigError
from hil.config.rig import load_rig
from hil.flight.board_image import firmware_elf
from hil.flight.tickloop import EndReason
from hil.board.elf import load_elf
from hil.record import read_topic
from tests.system.conftest import explain

pytestmark = [pytest.mark.system]

ROOT = Path(__file__).resolve().parents[2]
BOARD_RIG = ROOT / "rigs" / "paper-quad-lpc2148.toml"
DURATION_S = 0.5
TIMEOUT_S = 120.0  #: a wait that would otherwise hang the test


@pytest.fixture(scope="module")
def elf() -> Path:
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("arm-none-eabi-gcc is not installed (firmware/install-toolchain.sh)")
    return firmware_elf(load_rig(BOARD_RIG))


class Client:
    """A minimal GDB remote-protocol client."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer
        self.decoder = rsp.Decoder()
        self.pending: list[rsp.Packet | rsp.Event] = []

    @classmethod
    async def connect(cls, port: int) -> Client:
        return cls(*await asyncio.open_connection("127.0.0.1", port))

    async def _next_packet(self) -> bytes:
        while True:
            while self.pending:
                item = self.pending.pop(0)
                if isinstance(item, rsp.Packet):
                    self.writer.write(b"+")
                    return item.data
            data = await asyncio.wait_for(self.reader.read(4096), TIMEOUT_S)
            assert data, "the bench closed the debugger's connection"
            self.pending += self.decoder.feed(data)

    async def ask(self, command: str) -> str:
        self.writer.write(rsp.encode(command.encode()))
        return (await self._next_packet()).decode("latin-1")

    def interrupt(self) -> None:
        self.writer.write(bytes([rsp.INTERRUPT_BYTE]))

    async def wait_stop(self) -> str:
        return (await self._next_packet()).decode("latin-1")

    def register(self, g_reply: str, n: int) -> int:
        return int.from_bytes(bytes.fromhex(g_reply[8 * n : 8 * n + 8]), "little")


async def test_a_debugger_holds_the_core_and_the_flight_is_the_same(fly, elf: Path, tmp_path: Path) -> None:
    image = load_elf(elf)
    loop_tick = image.symbol("loop_tick") & ~1
    seen: dict[str, object] = {}
    done = asyncio.Event()

    async def session(port: int) -> None:
        gdb = await Client.connect(port)
        try:
            assert "qXfer:features:read+" in await gdb.ask("qSupported:multiprocess+;xmlRegisters=arm")
            xml = await gdb.ask("qXfer:features:read:target.xml:0,fff")
            assert xml.startswith("l") and "org.gnu.gdb.arm.core" in xml and 'name="cpsr"' in xml
            assert await gdb.ask("?") == "S05"
            regs = await gdb.ask("g")
            seen["reset_pc"] = gdb.register(regs, 15)
            assert await gdb.ask(f"Z0,{loop_tick:x},4") == "OK"
            gdb.writer.write(rsp.encode(b"c"))
            assert await gdb.wait_stop() == "S05"
            regs = await gdb.ask("g")
            seen["bp_pc"] = gdb.register(regs, 15)
            sp = gdb.register(regs, 13)
            seen["stack"] = await gdb.ask(f"m{sp:x},10")
            seen["peripheral"] = await gdb.ask("me0000000,4")  # UART0's RBR: reading it would take a byte
            gdb.writer.write(rsp.encode(b"s"))
            assert await gdb.wait_stop() == "S05"
            seen["step_pc"] = int.from_bytes(bytes.fromhex(await gdb.ask("pf")), "little")
            assert await gdb.ask(f"z0,{loop_tick:x},4") == "OK"
            gdb.writer.write(rsp.encode(b"c"))
            gdb.interrupt()
            seen["interrupt"] = await gdb.wait_stop()
            assert await gdb.ask("D") == "OK"
        finally:
            gdb.writer.close()
            done.set()

    def on_ready(loop, devices, runner) -> None:  # type: ignore[no-untyped-def]
        seen["task"] = asyncio.ensure_future(session(loop.gdb.port))

    held = await fly("hover", rig=str(BOARD_RIG), duration_s=DURATION_S, out_dir=tmp_path / "held", gdb_port=0,
                     on_ready=on_ready)
    await asyncio.wait_for(done.wait(), TIMEOUT_S)
    task = seen.pop("task")
    assert isinstance(task, asyncio.Task)
    await task  # its assertions
    assert held.end_reason is EndReason.COMPLETED, explain(held)
    assert seen["reset_pc"] == image.entry and seen["bp_pc"] == loop_tick  # held before the first instruction
    assert seen["step_pc"] in (loop_tick + 2, loop_tick + 4)  # one Thumb or ARM instruction on
    assert isinstance(seen["stack"], str) and len(seen["stack"]) == 32
    assert seen["peripheral"] == "E01" and seen["interrupt"] == "S02"
    assert any("GDB port" in n for n in held.notes)

    plain = await fly("hover", rig=str(BOARD_RIG), duration_s=DURATION_S, out_dir=tmp_path / "plain")
    assert plain.end_reason is EndReason.COMPLETED, explain(plain)
    assert held.trace is not None and plain.trace is not None
    for name in ("truth.h_m", "truth.roll_deg", "esc.cmd_us"):
        assert np.array_equal(held.trace.signal(name)[1], plain.trace.signal(name)[1]), name


async def test_kill_ends_the_run_with_its_log(fly, elf: Path, tmp_path: Path) -> None:
    async def session(port: int) -> None:
        gdb = await Client.connect(port)
        assert await gdb.ask("?") == "S05"
        gdb.writer.write(rsp.encode(b"k"))
        await gdb.writer.drain()
        gdb.writer.close()

    tasks: list[asyncio.Task[None]] = []
    result = await fly("hover", rig=str(BOARD_RIG), duration_s=DURATION_S, gdb_port=0,
                       on_ready=lambda loop, *_: tasks.append(asyncio.ensure_future(session(loop.gdb.port))))
    await tasks[0]
    # killed at reset, so in the boot: the boot's end names the debugger
    assert result.end_reason is EndReason.BOOT_FAILED, explain(result)
    assert "the debugger ended the firmware (GDB kill)" in result.message, explain(result)
    assert result.log_path is not None and read_topic(result.log_path, "/hil/verdict")


async def test_gdb_on_a_process_rig_is_refused(fly) -> None:
    with pytest.raises(ConfigError, match="--gdb: the rig's flight code is a process"):
        await fly("hover", gdb_port=0)


@pytest.mark.skipif(shutil.which("gdb-multiarch") is None, reason="gdb-multiarch: firmware/install-toolchain.sh")
def test_gdb_stops_at_the_loop_and_shows_where(elf: Path, tmp_path: Path) -> None:
    bench = subprocess.Popen(
        [sys.executable, "-m", "hil.cli", "run", str(BOARD_RIG), "-s", "hover", "--duration", str(DURATION_S),
         "--gdb", "0", "--out", str(tmp_path), "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert bench.stderr is not None
        line = bench.stderr.readline()  # the announcement: the bench waits for GDB
        assert "waits for GDB on 127.0.0.1:" in line, line
        port = int(line.split("127.0.0.1:")[1].split(":")[0])
        gdb = subprocess.run(
            ["gdb-multiarch", "-nx", "-batch", str(elf), "-ex", f"target remote :{port}", "-ex", "break loop_tick",
             "-ex", "continue", "-ex", "bt 2", "-ex", "info registers pc", "-ex", "delete", "-ex", "detach"],
            capture_output=True, text=True, timeout=TIMEOUT_S)
        assert "Breakpoint 1, loop_tick" in gdb.stdout, gdb.stdout + gdb.stderr
        assert "#1" in gdb.stdout and "pc " in gdb.stdout, gdb.stdout
        out, err = bench.communicate(timeout=TIMEOUT_S)
        assert bench.returncode in (0, 1), err
        assert "completed" in out or "PASS" in out, out
    finally:
        if bench.poll() is None:
            bench.kill()
            bench.wait()
