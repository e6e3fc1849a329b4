"""``hil build``: compile the device models, the plant and the tick path with mypyc.

The build runs in a child process (hil/native/compile.py) in a temporary directory beside the
build directory, and replaces the old build only once it is whole: an interrupted or failed
build leaves the previous one (or none) in place and no temporary directory behind. The
manifest records a stamp of every watched source taken *before* mypyc reads them, so a source
edited while the build runs makes the new build stale at once rather than silently wrong.

Needs a C compiler, Python's headers (``Python.h``), mypy and setuptools (both installed with
the bench). Each missing piece stops the build before it starts, with one sentence on what to
install.
"""

from __future__ import annotations

import collections
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
from collections.abc import Callable
from pathlib import Path

from hil import clock
from hil.native import manifest as manifest_mod
from hil.native.loader import build_dir
from hil.native.sources import OPT_LEVELS, project_root, watched_sources

_BUILDING = "building '"
_LARGEST = "hil-build-largest: "
#: C lines of one mypyc group that one core compiles per minute at -O3 on the 2-core machine of
#: docs/performance.md, Builds (540,000 lines in 6-9 min): for the estimate shown while a large
#: group compiles, +-30 %
C_LINES_PER_MIN = 75_000


class BuildError(Exception):
    """The build cannot start or failed; the message says what to do."""


def _compiler_command() -> list[str]:
    return shlex.split(os.environ.get("CC") or str(sysconfig.get_config_var("CC") or "cc"))


def preflight() -> None:
    """Raise BuildError naming what to install when the build could not succeed."""
    cc = _compiler_command()
    if not cc or shutil.which(cc[0]) is None:
        raise BuildError(f"no C compiler ({cc[0] if cc else 'CC'} not found): install one "
                         "(Debian/Ubuntu: apt install gcc libc6-dev)")
    headers = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not headers.exists():
        raise BuildError(f"{headers} is missing: install Python's headers "
                         f"(Debian/Ubuntu: apt install python3-dev; Fedora: dnf install python3-devel)")
    for module, package in (("mypyc", "mypy"), ("setuptools", "setuptools")):
        try:
            __import__(module)
        except ImportError:
            raise BuildError(f"{module} is not installed in this environment: "
                             f"{sys.executable} -m pip install {package}") from None


def _module_of(rel: Path) -> str:
    """``emulators/rc/ppm.cpython-311-x86_64-linux-gnu.so`` -> ``emulators.rc.ppm``."""
    parts = [*rel.parent.parts, rel.name.split(".")[0]]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def largest_note(c_files: int, lines: int, opt_level: str) -> str:
    """What the build is doing while its largest group compiles, with a rough duration."""
    low = max(1, round(lines / C_LINES_PER_MIN * 0.7))
    high = max(low + 1, round(lines / C_LINES_PER_MIN * 1.3))
    files = "1 C file" if c_files == 1 else f"{c_files} C files"
    return f"compiling {files} of {lines:,} lines at -O{opt_level}, about {low}-{high} min on one core"


def _run_compiler(tmp: Path, root: Path, grouping: str, opt_level: str, jobs: int,
                  progress: Callable[[int, int], None], note: Callable[[str], None]) -> None:
    argv = [sys.executable, "-m", "hil.native.compile", str(tmp), "--groups", grouping, "--opt-level", opt_level,
            "--jobs", str(jobs)]
    tail: collections.deque[str] = collections.deque(maxlen=40)
    total = done = 0
    with subprocess.Popen(argv, cwd=root, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          stdin=subprocess.DEVNULL) as proc:
        assert proc.stdout is not None
        try:
            for line in proc.stdout:
                tail.append(line.rstrip())
                if line.startswith("hil-build: "):
                    total = int(line.split()[1])
                    progress(0, total)
                elif line.startswith(_LARGEST):
                    c_files, lines, _name = line[len(_LARGEST):].split()
                    if int(lines) >= C_LINES_PER_MIN:  # a group that takes a minute or more
                        note(largest_note(int(c_files), int(lines), opt_level))
                elif line.startswith(_BUILDING):
                    done += 1
                    progress(done, total)
        except BaseException:
            proc.kill()
            raise
    if proc.returncode != 0:
        raise BuildError("the compiler failed (exit status %d); its last lines:\n%s"
                         % (proc.returncode, "\n".join(tail)))


def build(*, groups: str = "modules", opt_level: str | None = None, jobs: int | None = None,
          directory: Path | None = None, progress: Callable[[int, int], None] = lambda done, total: None,
          note: Callable[[str], None] = lambda text: None) -> manifest_mod.Manifest:
    """Compile into ``directory`` (default: hil.native.build_dir(), where ``import hil`` looks)
    and return its manifest.

    ``groups``: sources.GROUPINGS (one extension per module, or one group for all);
    ``opt_level``: mypyc's, by default the grouping's (sources.OPT_LEVELS).
    ``progress(done, total)``: extension modules started so far (0 of N once the C exists);
    ``note(text)``: what a long step is doing (a large group compiling).
    ``jobs``: parallel compiler processes (default: the CPUs this process may use)."""
    opt_level = opt_level or OPT_LEVELS[groups]
    preflight()
    root = project_root()
    final = directory or build_dir()
    final.parent.mkdir(parents=True, exist_ok=True)
    stamps = {rel: manifest_mod.SourceStamp.of(root / rel) for rel in watched_sources(root)}
    started_ns = clock.wall_ns()
    tmp = final.parent / f".{final.name}.building-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        _run_compiler(tmp, root, groups, opt_level, jobs or len(os.sched_getaffinity(0)), progress, note)
        lib = tmp / "lib"
        modules = {_module_of(p.relative_to(lib)): p.relative_to(lib).as_posix() for p in sorted(lib.rglob("*.so"))}
        m = manifest_mod.Manifest(root=str(root), interpreter=manifest_mod.interpreter_tag(), opt_level=opt_level,
                                  groups=groups, built_ns=started_ns, modules=modules, sources=stamps)
        m.write(lib)
        _swap_in(lib, final)
        return m
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _swap_in(new: Path, final: Path) -> None:
    """Replace ``final`` by ``new`` (processes that mapped the old modules keep them)."""
    old = final.with_name(f".{final.name}.old-{os.getpid()}")
    if final.exists():
        final.rename(old)
    new.rename(final)
    shutil.rmtree(old, ignore_errors=True)


def clean() -> bool:
    """Remove the build; False if there was none."""
    final = build_dir()
    if not final.exists():
        return False
    shutil.rmtree(final)
    return True
