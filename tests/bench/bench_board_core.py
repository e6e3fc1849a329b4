"""Benchmark of the emulated LPC2148's core (not a test): what the cycle accounting costs.

Run: ``.venv/bin/python tests/bench/bench_board_core.py [--repeats N]``

Two loops, each run three ways, interleaved, on this process's CPU time (a loaded machine
changes wall time, less so CPU time):

- ``alu``: ADD, LDR, MUL, STR, CMP, BNE (6 instructions a pass, the MUL's operand read at the
  block's end);
- ``softfloat``: a C loop of float multiply-adds compiled with arm-none-eabi-gcc -O2 (libgcc's
  __aeabi_fmul/__aeabi_fadd: conditional execution, UMULL read by a probe);

1. ``off``: bare Unicorn (``emu_start`` to the loop's end, no hook): no cycle accounting;
2. ``on``: the board's core (hil/board: the C block hook, items, probes, the MAM), to the same
   address;
3. ``python-hook``: bare Unicorn with a Python UC_HOOK_BLOCK that only counts (what a
   per-block Python call costs, the design the C hook replaces).

Prints MIPS (emulated instructions per host CPU second) and, for ``on``, emulated MHz (CCLK
cycles per host CPU second): 60 would be real time for a core that never sleeps.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from unicorn import UC_ARCH_ARM, UC_HOOK_BLOCK, UC_MODE_ARM, Uc  # noqa: E402
from unicorn import arm_const as A  # noqa: E402

from emulators.lpc2148 import Lpc2148  # noqa: E402
from hil.board.core import SRAM_BASE, Core  # noqa: E402
from hil.board.elf import load_elf  # noqa: E402

ALU = r"""
    .syntax unified
    .global _start
_start:
    mov r0, #0
    ldr r1, =PASSES
    mov r4, #0x40000000
    add r4, r4, #0x1000
loop:
    add r0, r0, #1
    ldr r2, [r4]
    mul r3, r2, r0
    str r3, [r4, #4]
    cmp r0, r1
    bne loop
done:
    b done
"""

SOFTFLOAT = r"""
volatile float sink;
float acc(float x, float k, int n) {
    float y = 0.0f;
    for (int i = 0; i < n; i++) { y = y * k + x; x = x * 0.999f + 0.001f; }
    return y;
}
void _start(void) {
    sink = acc(1.5f, 0.95f, PASSES);
    for (;;) {}
}
"""


def build(tmp: Path, kind: str, passes: int) -> Path:
    elf = tmp / f"{kind}-{passes}.elf"
    if kind == "alu":
        src = tmp / "alu.S"
        src.write_text(ALU.replace("PASSES", str(passes)))
        cmd = ["arm-none-eabi-gcc", "-mcpu=arm7tdmi", "-nostdlib", "-Wl,-Ttext=0x40000000", "-o", str(elf), str(src)]
    else:
        src = tmp / "softfloat.c"
        src.write_text(SOFTFLOAT.replace("PASSES", str(passes)))
        cmd = ["arm-none-eabi-gcc", "-O2", "-mcpu=arm7tdmi", "-marm", "-mfloat-abi=soft", "-nostartfiles",
               "-Wl,-Ttext=0x0", "-Wl,-Tdata=0x40000000", "-o", str(elf), str(src), "-lgcc"]
    subprocess.run(cmd, check=True)
    return elf


def end_of(elf: Path) -> tuple[int, int]:
    image = load_elf(elf)
    start = image.symbols["_start"]
    if "done" in image.symbols:
        return start, image.symbols["done"]
    # softfloat: the `for (;;)` after the store to sink; find the branch to itself
    code = b"".join(s.data for s in image.segments if s.executable)
    base = min(s.address for s in image.segments if s.executable)
    for off in range(image.symbols["_start"] - base, len(code), 4):
        if code[off:off + 4] == b"\xfe\xff\xff\xea":
            return start, base + off
    raise SystemExit("no `b .` in the soft-float program")


def bare(elf: Path, python_hook: bool) -> tuple[float, int]:
    image = load_elf(elf)
    start, end = end_of(elf)
    uc = Uc(UC_ARCH_ARM, UC_MODE_ARM)
    uc.ctl_set_cpu_model(A.UC_CPU_ARM_TI925T)
    uc.mem_map(0, 512 * 1024)
    uc.mem_map(SRAM_BASE, 32 * 1024)
    for seg in image.segments:
        uc.mem_write(seg.address, seg.data)
    uc.reg_write(A.UC_ARM_REG_SP, SRAM_BASE + 0x7000)
    blocks = [0]
    if python_hook:
        def count(_uc: Uc, _a: int, _s: int, _u: object) -> None:
            blocks[0] += 1
        uc.hook_add(UC_HOOK_BLOCK, count)
    t = time.process_time()
    uc.emu_start(start, end)
    return time.process_time() - t, blocks[0]


def board(elf: Path) -> tuple[float, int, int]:
    image = load_elf(elf)
    start, end = end_of(elf)
    bus = Lpc2148()
    bus.scb.mamcr, bus.scb.mamtim = 2, 3
    core = Core(bus)
    core.mmio.memory_timing_changed()
    core.load(image)
    core.reset(start)
    core.set_reg(A.UC_ARM_REG_SP, SRAM_BASE + 0x7000)
    t = time.process_time()
    cycles = core.run_to(end, 10**12)
    return time.process_time() - t, int(core.counter.state.instructions), cycles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for kind, passes in (("alu", 2_000_000), ("softfloat", 100_000)):
            elf = build(tmp, kind, passes)
            _, instructions, cycles = board(elf)  # translation warm-up, and the instruction count
            rows: dict[str, list[float]] = {"off": [], "on": [], "python-hook": []}
            for _ in range(args.repeats):
                rows["off"].append(bare(elf, False)[0])
                rows["on"].append(board(elf)[0])
                rows["python-hook"].append(bare(elf, True)[0])
            print(f"{kind}: {instructions:,} instructions, {cycles:,} cycles ({cycles / instructions:.2f} CPI), "
                  f"median of {args.repeats}")
            for name, times in rows.items():
                s = statistics.median(times)
                extra = f", {cycles / s / 1e6:6.1f} emulated MHz" if name == "on" else ""
                print(f"  {name:12s} {s * 1e3:8.1f} ms  {instructions / s / 1e6:6.1f} MIPS{extra}")


if __name__ == "__main__":
    main()
