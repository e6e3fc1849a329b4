"""The ARM build's flash, RAM and stack use against the LPC2148's 512 KB / 32 KB.

    python size_report.py build/arm/fc.elf --callgraph-dir build/arm/obj [--min-spare 25]

Flash: every allocated section with a load address in flash (code, read-only data, the
initial values of .data). RAM: .data and .bss (the static image) plus the regions the linker
script reserves for the stacks (symbols ``__stack_size`` for the main stack and, if defined,
``__irq_stack_size``/``__fiq_stack_size``...: any symbol ``__*stack_size``) and a heap
(``__heap_size``). Stack: the deepest call chain from ``main`` by GCC's call-graph files
(``-fcallgraph-info=su``: each function's static frame); a call through a pointer counts as
the deepest of the functions no one calls directly (the callbacks); library functions without
a call-graph file count 0 and are listed. The worst chain is compared with ``__stack_size``.

Prints a table and one machine-readable line, ``size_report: {json}``; exit 1 if flash or RAM
has less than --min-spare percent spare, or the stack chain does not fit its reservation.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from functools import lru_cache
from pathlib import Path

from elftools.elf.constants import SH_FLAGS
from elftools.elf.elffile import ELFFile
from elftools.elf.sections import SymbolTableSection

FLASH_BASE, FLASH_SIZE = 0x0000_0000, 512 * 1024
RAM_BASE, RAM_SIZE = 0x4000_0000, 32 * 1024
INDIRECT = "__indirect_call"

_NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
_EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
_FRAME = re.compile(r"\\n(\d+) bytes \((static|dynamic|dynamic,bounded)\)")


def sections(elf: ELFFile) -> tuple[int, int, int, dict[str, int]]:
    """(flash bytes, .data bytes, .bss-like bytes, every allocated section's size): a writable
    section lives in RAM (with its initial values in flash unless it is NOBITS); the rest is
    flash. Stack and heap regions the linker script reserves as sections are left to
    :func:`reserved` (counted once, by their size symbols)."""
    flash = data = bss = 0
    sizes: dict[str, int] = {}
    for sec in elf.iter_sections():
        if not sec["sh_flags"] & SH_FLAGS.SHF_ALLOC or sec["sh_size"] == 0:
            continue
        size = sec["sh_size"]
        sizes[sec.name] = size
        nobits = sec["sh_type"] == "SHT_NOBITS"
        if re.search(r"stack|heap", sec.name):
            continue
        if sec["sh_flags"] & SH_FLAGS.SHF_WRITE:
            if nobits:
                bss += size
            else:
                data += size
                flash += size  # its initial values are copied from flash at start-up
        elif not nobits:
            flash += size
    return flash, data, bss, sizes


def functions(elf: ELFFile) -> set[str]:
    """Names of the functions the image holds (after --gc-sections)."""
    out: set[str] = set()
    for sec in elf.iter_sections():
        if isinstance(sec, SymbolTableSection):
            out.update(sym.name for sym in sec.iter_symbols() if sym["st_info"]["type"] == "STT_FUNC")
    return out


def reserved(elf: ELFFile) -> dict[str, int]:
    """The linker script's size symbols: stacks and heap, bytes."""
    out: dict[str, int] = {}
    for sec in elf.iter_sections():
        if isinstance(sec, SymbolTableSection):
            for sym in sec.iter_symbols():
                name = sym.name
                if re.fullmatch(r"__\w*stack_size(__)?", name) or re.fullmatch(r"__heap_size(__)?", name):
                    out[name.strip("_")] = int(sym["st_value"])
    return out


def call_graph(directory: Path) -> tuple[dict[str, int], dict[str, set[str]]]:
    """Every function's static frame (bytes) and its callees, from ``*.ci`` files; static
    functions are named ``file:name``."""
    frames: dict[str, int] = {}
    calls: dict[str, set[str]] = {}
    for ci in sorted(directory.rglob("*.ci")):
        text = ci.read_text(errors="replace")
        for title, label in _NODE.findall(text):
            m = _FRAME.search(label)
            if m:
                frames[title] = int(m.group(1))
        for src, dst in _EDGE.findall(text):
            calls.setdefault(src, set()).add(dst)
    return frames, calls


def worst_chain(frames: dict[str, int], calls: dict[str, set[str]], root: str,
                linked: set[str]) -> tuple[int, list[str], set[str]]:
    """(bytes, the chain, functions with no frame information) of the deepest path from
    ``root``. A call through a pointer may reach any function of the image that nothing
    calls directly (the callbacks)."""
    called = {dst for dsts in calls.values() for dst in dsts}
    callbacks = [f for f in frames if f not in called and f != root and f.split(":")[-1] in linked]
    unknown: set[str] = set()
    visiting: set[str] = set()

    @lru_cache(maxsize=None)
    def depth(fn: str) -> tuple[int, tuple[str, ...]]:
        if fn in visiting:
            raise RecursionError(f"recursion through {fn}: the stack has no static bound")
        if fn == INDIRECT:
            targets = callbacks
            own = 0
        else:
            if fn not in frames:
                unknown.add(fn)
            targets = sorted(calls.get(fn, ()))
            own = frames.get(fn, 0)
        visiting.add(fn)
        best: tuple[int, tuple[str, ...]] = (0, ())
        for t in targets:
            if t == fn:
                continue
            d = depth(t)
            if d[0] > best[0]:
                best = d
        visiting.discard(fn)
        return own + best[0], ((fn,) if fn != INDIRECT else ()) + best[1]

    total, chain = depth(root)
    return total, list(chain), unknown


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("elf", type=Path)
    ap.add_argument("--callgraph-dir", type=Path, required=True)
    ap.add_argument("--min-spare", type=float, default=25.0, help="percent of flash and RAM that must stay free")
    args = ap.parse_args(argv)
    with args.elf.open("rb") as f:
        elf = ELFFile(f)
        flash, data, bss, sizes = sections(elf)
        res = reserved(elf)
        linked = functions(elf)
    stack_reserved = res.get("stack_size", 0)
    other = sum(v for k, v in res.items() if k != "stack_size")
    ram = data + bss + stack_reserved + other
    frames, calls = call_graph(args.callgraph_dir)
    try:
        stack, chain, unknown = worst_chain(frames, calls, "main", linked)
        stack_note = ""
    except RecursionError as exc:
        stack, chain, unknown, stack_note = -1, [], set(), str(exc)
    flash_spare = 100.0 * (1 - flash / FLASH_SIZE)
    ram_spare = 100.0 * (1 - ram / RAM_SIZE)
    print(f"firmware ARM build {args.elf} (LPC2148: {FLASH_SIZE // 1024} KB flash, {RAM_SIZE // 1024} KB RAM)")
    print(f"  flash {flash:>8,} B  {100 - flash_spare:5.1f} % used, {flash_spare:5.1f} % spare  "
          f"(code and constants; .data's initial values)")
    print(f"  RAM   {ram:>8,} B  {100 - ram_spare:5.1f} % used, {ram_spare:5.1f} % spare  "
          f"(.data {data:,} + .bss {bss:,} + main stack {stack_reserved:,}"
          + "".join(f" + {k} {v:,}" for k, v in sorted(res.items()) if k != "stack_size") + ")")
    if stack >= 0:
        short = " -> ".join(c.split(":")[-1] for c in chain)
        print(f"  stack {stack:>8,} B  deepest call chain from main (static frames): {short}")
        libs = sorted(u for u in unknown if u != INDIRECT)
        if libs:
            print(f"        not counted (no call-graph file: library code): {', '.join(libs[:12])}"
                  + (" ..." if len(libs) > 12 else ""))
    else:
        print(f"  stack: {stack_note}")
    stack_fits = stack >= 0 and (stack_reserved == 0 or stack <= stack_reserved)
    report = {"flash_B": flash, "flash_total_B": FLASH_SIZE, "ram_B": ram, "ram_total_B": RAM_SIZE,
              "data_B": data, "bss_B": bss, "stack_reserved_B": stack_reserved, "stack_worst_B": stack,
              "flash_spare_pct": round(flash_spare, 2), "ram_spare_pct": round(ram_spare, 2),
              "min_spare_pct": args.min_spare, "sections": sizes}
    print("size_report: " + json.dumps(report, sort_keys=True))
    ok = flash_spare >= args.min_spare and ram_spare >= args.min_spare and stack_fits
    if not ok:
        print(f"size_report: FAIL (need {args.min_spare:g} % spare of flash and RAM, and the deepest chain "
              "within the main stack)", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
