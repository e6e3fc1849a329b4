"""The emulated board is deterministic: the same program and the same inputs at the same cycles
give the same cycle counts and the same outputs at the same cycles, whatever the host does
(here: once alone, once beside two CPU hogs)."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.unit.board.armfw import build_on_hal
from tests.unit.board.test_lpc2148_hal import MS, PROBE, boot


@contextmanager
def cpu_hogs(n: int) -> Iterator[None]:
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
        for hog in hogs:
            hog.wait(timeout=10)


def fly(elf: Path) -> dict[str, object]:
    core, bus, _ = boot(elf)
    bus.attach_spi_slave(lambda mosi, transfer: (mosi * 7 + 3) & 0xFF)
    lines: list[tuple[int, str]] = []
    core.semihost.on_line = lambda line: lines.append((core.cycles, line))
    entries: list[tuple[str, int, int]] = []
    core.on_interrupt = lambda kind, requested, entry: entries.append((kind, requested, entry))
    core.run_until(3 * MS)
    for k in range(5):
        bus.uart_line_in(0, bytes(range(k, k + 40)), core.cycles, baud=921600)
        core.run_until(core.cycles + 2 * MS + 137 * k)
        bus.pin_edge(0, 10, k % 2 == 0, core.cycles)
        core.run_until(core.cycles + 3 * MS)
    core.run_until(300 * MS)
    state = core.counter.state
    return {
        "cycles": core.cycles, "blocks": int(state.blocks), "instructions": int(state.instructions),
        "idle": core.idle_cycles, "lines": lines, "interrupts": entries,
        "uart1": [(tx.value, tx.start_cycle) for tx in bus.take_uart_tx(1)],
        "pwm": bus.take_pwm(), "mat": bus.timer1.take_match_outputs(),
    }


def test_same_inputs_same_cycles_alone_and_beside_cpu_hogs() -> None:
    elf = build_on_hal(PROBE)
    alone = fly(elf)
    with cpu_hogs(2):
        loaded = fly(elf)
    assert alone == loaded
    assert len(alone["lines"]) > 10 and len(alone["interrupts"]) > 50  # type: ignore[arg-type]
