"""Where the firmware's cycles go on the emulated LPC2148 (a benchmark, not a test).

Run: ``.venv/bin/python tests/bench/bench_board_profile.py [--scenario hover] [--duration 6]
[--top 15]``. Flies the board rig (rigs/paper-quad-lpc2148.toml) with a Unicorn block hook that
charges the cycles between two translated blocks to the function (ELF symbol) of the first, and
cuts them at each entry of ``loop_tick`` (one sample's iteration). Prints, for the iteration of
median busy cycles and for the busiest one, the functions that took the most cycles (the idle
loop ``lpc_idle`` and ``lpc_wait`` are the core asleep, not counted as busy). The hook is one
Python call per block, so the flight runs about 5 times slower than without it; the cycles are
the cycle model's and do not change. Prints; asserts nothing.
"""

from __future__ import annotations

import argparse
import asyncio
import bisect
import collections
import statistics
import sys
import tempfile
from pathlib import Path

from elftools.elf.elffile import ELFFile
from unicorn import UC_HOOK_BLOCK

import hil.board.core as board_core
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight.run import run_flight_async

ROOT = Path(__file__).resolve().parents[2]
RIG = ROOT / "rigs" / "paper-quad-lpc2148.toml"
ELF = ROOT / "firmware" / "build" / "arm" / "fc.elf"
ASLEEP = ("lpc_idle", "lpc_wait")


def functions(elf: Path) -> tuple[list[int], list[str]]:
    """Start addresses (sorted, Thumb bit cleared) and names of the ELF's functions."""
    with elf.open("rb") as f:
        symtab = ELFFile(f).get_section_by_name(".symtab")
        syms = sorted((s["st_value"] & ~1, s.name) for s in symtab.iter_symbols()
                      if s["st_info"]["type"] == "STT_FUNC" and s["st_value"])
    return [a for a, _ in syms], [n for _, n in syms]


class Profile:
    """Cycles per function per loop iteration, from a block hook on the board's core."""

    def __init__(self, elf: Path) -> None:
        self.addrs, self.names = functions(elf)
        self.tick = self.addrs[self.names.index("loop_tick")]
        self.iterations: list[collections.Counter[str]] = [collections.Counter()]
        self._fn = "?"
        self._t = 0

    def install(self) -> None:
        original = board_core.Core.__init__
        profile = self

        def init(core: board_core.Core, *args: object, **kwargs: object) -> None:
            original(core, *args, **kwargs)  # type: ignore[arg-type]
            core.uc.hook_add(UC_HOOK_BLOCK, lambda uc, address, size, _: profile.block(core, address))

        board_core.Core.__init__ = init  # type: ignore[method-assign]

    def block(self, core: board_core.Core, address: int) -> None:
        now = core.cycles
        self.iterations[-1][self._fn] += now - self._t
        self._t = now
        if address == self.tick:
            self.iterations.append(collections.Counter())
        i = bisect.bisect_right(self.addrs, address) - 1
        self._fn = self.names[i] if i >= 0 else "?"

    @staticmethod
    def busy(it: collections.Counter[str]) -> int:
        return sum(v for k, v in it.items() if k not in ASLEEP)


def show(title: str, it: collections.Counter[str], top: int) -> None:
    busy = Profile.busy(it)
    print(f"{title}: {busy} busy cycles ({busy / 60:.0f} us at 60 MHz)")
    for name, cycles in [(k, v) for k, v in it.most_common() if k not in ASLEEP][:top]:
        print(f"  {cycles:>7} {100 * cycles / busy:5.1f} %  {name}")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="hover")
    ap.add_argument("--duration", type=float, default=6.0)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--from-s", type=float, default=1.0, help="Leave out iterations before this sim time (boot).")
    a = ap.parse_args(argv)
    rig = load_rig(RIG)
    source = rig.scenario_path(a.scenario)
    scenario = load_scenario(source)
    if not ELF.is_file():
        print("firmware/build/arm/fc.elf is missing: `hil firmware build --target arm` first", file=sys.stderr)
        return 2
    p = Profile(ELF)
    p.install()
    with tempfile.TemporaryDirectory() as out:
        r = asyncio.run(run_flight_async(rig, scenario, scenario_source=source, duration_s=a.duration,
                                         out_dir=Path(out)))
    # iteration k processed sample k (counted from the first loop_tick); leave out the boot's
    skip = int(a.from_s / (rig.tick_ns * 1e-9))
    its = p.iterations[1 + skip:-1]
    if not its:
        print("no loop iterations after --from-s", file=sys.stderr)
        return 2
    busy = [Profile.busy(it) for it in its]
    print(f"{a.scenario} {a.duration} s on the board ({r.end_reason.value}): {len(its)} iterations from "
          f"{a.from_s} s; busy cycles p50 {statistics.median(busy):.0f}, max {max(busy)}")
    order = sorted(range(len(its)), key=busy.__getitem__)
    show("the median iteration", its[order[len(order) // 2]], a.top)
    show("the busiest iteration", its[order[-1]], a.top)
    total: collections.Counter[str] = collections.Counter()
    for it in its:
        total.update(it)
    show(f"all {len(its)} iterations", total, a.top)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
