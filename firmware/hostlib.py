"""Build firmware sources into a host shared library with the machine's C compiler, for tests
that load it with ctypes (tests/unit/firmware/). A build tool, not part of the bench.

The flags are the firmware's own: C11, single precision checked (``-Wdouble-promotion``,
``-Wfloat-conversion``), warnings are errors, and no floating-point contraction, so a product
and a sum round as the ARM7's soft-float library rounds them (no fused multiply-add on the
host either). A library is rebuilt only when a source, a header in the include directories,
the flags or the compiler change (the key is a hash of all of them).
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

FIRMWARE = Path(__file__).resolve().parent
SRC = FIRMWARE / "src"

#: Compile flags shared by every host build of the firmware's modules.
CFLAGS: tuple[str, ...] = (
    "-std=c11", "-O2", "-g", "-fPIC", "-ffp-contract=off",
    "-Wall", "-Wextra", "-Wpedantic", "-Wshadow", "-Wdouble-promotion", "-Wfloat-conversion", "-Wconversion",
    "-Werror",
)



def estctl_sources(src: Path = SRC) -> tuple[Path, ...]:
    """The estimation and control modules under ``src`` (firmware/src, or a mutant's copy of
    it); the parameter generator's headers are the caller's."""
    return tuple(sorted((src / "estimation").glob("*.c")) + sorted((src / "control").glob("*.c")))


class BuildError(RuntimeError):
    """The compiler failed: its command and output."""


def compiler() -> list[str]:
    """The C compiler command: $CC, else ``cc``."""
    cc = shlex.split(os.environ.get("CC") or "cc")
    if not cc or shutil.which(cc[0]) is None:
        raise BuildError(f"no C compiler: {cc[0] if cc else 'CC'} not found (Debian: apt install gcc libc6-dev)")
    return cc


def _key(sources: Sequence[Path], include_dirs: Sequence[Path], flags: Sequence[str]) -> str:
    h = hashlib.sha256()
    h.update(" ".join([*compiler(), *flags]).encode())
    for s in sources:
        h.update(str(s).encode())
        h.update(Path(s).read_bytes())
    for d in include_dirs:
        for hdr in sorted(Path(d).rglob("*.h")):
            h.update(str(hdr).encode())
            h.update(hdr.read_bytes())
    return h.hexdigest()[:16]


def build_shared(sources: Sequence[Path], out_dir: Path, name: str, include_dirs: Sequence[Path] = (),
                 defines: Sequence[str] = (), extra_flags: Sequence[str] = ()) -> Path:
    """Compile and link ``sources`` into ``out_dir/lib<name>-<key>.so``; returns its path.

    ``include_dirs`` come before firmware/src (so a generated header directory, or a mutant's
    copy of the sources, is searched first); ``defines`` are ``NAME`` or ``NAME=value``. BuildError with the compiler's output on
    failure.
    """
    incs = [*map(Path, include_dirs), SRC]
    flags = [*CFLAGS, *extra_flags, *(f"-D{d}" for d in defines), *(f"-I{d}" for d in incs)]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    lib = out_dir / f"lib{name}-{_key(sources, incs, flags)}.so"
    if lib.exists():
        return lib
    tmp = lib.with_suffix(f".{os.getpid()}.tmp")
    cmd = [*compiler(), *flags, "-shared", "-o", str(tmp), *map(str, sources), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise BuildError(f"{shlex.join(cmd)}\n{proc.stdout}{proc.stderr}")
    tmp.replace(lib)
    return lib
