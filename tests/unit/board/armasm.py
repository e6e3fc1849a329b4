"""Small ARM programs for the core's tests, assembled with arm-none-eabi-as and linked at a given
address (the same toolchain the firmware's ARM build uses; the tests skip without it)."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest

from emulators.lpc2148 import Lpc2148
from hil.board.core import SRAM_BASE, Core
from hil.board.elf import load_elf

AS, LD = "arm-none-eabi-as", "arm-none-eabi-ld"
_CACHE = Path(tempfile.gettempdir()) / f"hil-board-asm-{hashlib.sha1(str(Path(__file__)).encode()).hexdigest()[:8]}"


def need_toolchain() -> None:
    if shutil.which(AS) is None or shutil.which(LD) is None:
        pytest.skip("arm-none-eabi binutils are not installed (the firmware's ARM build installs them)")


@dataclass(frozen=True)
class Program:
    elf: Path
    symbols: dict[str, int]


def assemble(source: str, base: int = SRAM_BASE) -> Program:
    """``source`` (GNU as, ARM7TDMI) linked with .text at ``base``; its labels as symbols."""
    need_toolchain()
    text = ".syntax unified\n.cpu arm7tdmi\n.global _start\n" + source
    key = hashlib.sha1(f"{base:#x}\n{text}".encode()).hexdigest()[:16]
    _CACHE.mkdir(exist_ok=True)
    elf = _CACHE / f"{key}.elf"
    if not elf.exists():
        src, obj = _CACHE / f"{key}.s", _CACHE / f"{key}.o"
        src.write_text(text)
        tmp = _CACHE / f"{key}.{id(text)}.tmp"
        for cmd in ([AS, "-o", str(obj), str(src)], [LD, "-Ttext", f"{base:#x}", "-e", "_start", "-o", str(tmp), str(obj)]):
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode:
                raise AssertionError(f"{cmd[0]} failed on {src}:\n{done.stderr}")
        tmp.replace(elf)
    return Program(elf, load_elf(elf).symbols)


def core_with(program: Program, bus: Lpc2148 | None = None) -> tuple[Core, Lpc2148]:
    """A core (on the real peripheral models) with ``program`` loaded, reset at ``_start``."""
    bus = bus if bus is not None else Lpc2148()
    core = Core(bus)
    core.load(load_elf(program.elf))
    core.reset(program.symbols["_start"])
    return core, bus


def cycles_between(program: Program, first: str, second: str, bus: Lpc2148 | None = None,
                   limit: int = 1_000_000) -> int:
    """Cycles from label ``first`` to label ``second`` of one run of ``program``."""
    core, _ = core_with(program, bus)
    a = core.run_to(program.symbols[first], limit)
    b = core.run_to(program.symbols[second], limit)
    return b - a
