"""Can the clock shim be preloaded into this flight code? Where is it?

The shim is a C shared library built by the package's own install (``hil.vtime._shim``, a
setuptools extension without a Python module init: it is never imported, only preloaded).
LD_PRELOAD works for dynamically linked programs started without secure-execution; a static
binary, a set-user-ID program or another OS cannot be preloaded, and the run falls back to
wall-clock lockstep, saying so (``Fallback``).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import stat
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

PT_INTERP = 3


@dataclass(frozen=True)
class Fallback:
    """Why virtual time is off for a run (shown in the summary and the MCAP metadata)."""

    reason: str


def shim_library() -> Path | Fallback:
    """The built shim, or why there is none."""
    if not sys.platform.startswith("linux"):
        return Fallback(f"virtual time needs Linux (this is {sys.platform})")
    spec = importlib.util.find_spec("hil.vtime._shim")
    if spec is None or spec.origin is None or not Path(spec.origin).is_file():
        return Fallback("the clock shim was not built (reinstall the package: pip install -e .)")
    return Path(spec.origin)


def _elf_is_dynamic(path: Path) -> bool | None:
    """True if the ELF file has a program interpreter (so ld.so honours LD_PRELOAD), False
    for a static executable, None if it is not an ELF file."""
    try:
        with path.open("rb") as f:
            ident = f.read(16)
            if ident[:4] != b"\x7fELF":
                return None
            is64, little = ident[4] == 2, ident[5] == 1
            end = "<" if little else ">"
            if is64:
                f.seek(0x20)
                (phoff,) = struct.unpack(end + "Q", f.read(8))
                f.seek(0x36)
            else:
                f.seek(0x1C)
                (phoff,) = struct.unpack(end + "I", f.read(4))
                f.seek(0x2A)
            phentsize, phnum = struct.unpack(end + "HH", f.read(4))
            for i in range(phnum):
                f.seek(phoff + i * phentsize)
                (p_type,) = struct.unpack(end + "I", f.read(4))
                if p_type == PT_INTERP:
                    return True
            return False
    except (OSError, struct.error):
        return None


def _interpreter(path: Path) -> Path | None:
    """The program a ``#!`` script runs (resolving ``/usr/bin/env NAME``)."""
    try:
        with path.open("rb") as f:
            first = f.readline(512)
    except OSError:
        return None
    if not first.startswith(b"#!"):
        return None
    words = first[2:].decode(errors="replace").split()
    if not words:
        return None
    if Path(words[0]).name == "env" and len(words) > 1:
        found = shutil.which(words[1])
        return Path(found) if found else None
    return Path(words[0])


def check_program(argv: list[str]) -> Fallback | None:
    """None if the shim can be preloaded into ``argv``'s program, else why not."""
    found = shutil.which(argv[0]) if argv else None
    if found is None:
        return None  # the start itself will fail with a clear error
    path = Path(found)
    for _ in range(3):  # a script's interpreter may be a script
        mode = os.stat(path).st_mode
        if mode & (stat.S_ISUID | stat.S_ISGID):
            return Fallback(f"{path} is set-user/group-ID: the dynamic loader ignores LD_PRELOAD for it")
        dynamic = _elf_is_dynamic(path)
        if dynamic is True:
            return None
        if dynamic is False:
            return Fallback(f"{path} is statically linked: the clock shim cannot be preloaded into it")
        interp = _interpreter(path)
        if interp is None:
            return None  # unknown format: try, the attach check catches a miss
        path = interp
    return None
