"""The compiled parts ``pip install`` builds: the clock shim and the board's cycle counter.

``hil.vtime._shim`` is a plain C shared library preloaded into the flight code in lockstep runs
(docs/time.md). It has no Python module init and is never imported; ``hil.board._cyclehook``,
the emulated LPC2148's cycle counter, is the same kind of library, loaded with ctypes
(hil/board/native.py, docs/board.md). Everything else installs as
Python; ``hil build`` compiles the device models, the plant and the tick path afterwards, as an
option (docs/performance.md, Builds).

Without a C compiler the shim cannot be built: the install stops with one line saying what to
install, not with the compiler driver's error.
"""

from __future__ import annotations

import os
import shlex
import shutil
import sysconfig

from setuptools import Extension, setup


def require_c_compiler() -> None:
    cc = shlex.split(os.environ.get("CC") or str(sysconfig.get_config_var("CC") or "cc"))
    if not cc or shutil.which(cc[0]) is None:
        raise SystemExit(
            f"error: mav-hil-bench needs a C compiler to build its clock shim ({cc[0] if cc else 'CC'} "
            "not found): install one (Debian/Ubuntu: apt install gcc libc6-dev), then install again")


require_c_compiler()
shim = Extension(
    "hil.vtime._shim",
    sources=["hil/vtime/shim.c"],
    depends=["hil/vtime/hvt_abi.h"],
    extra_compile_args=["-fvisibility=hidden", "-U_FORTIFY_SOURCE", "-O2", "-Wall", "-Wextra"],
    libraries=["dl"],
)
# The emulated LPC2148's cycle counter (hil/board/cyclehook.c): Unicorn block and probe hooks in
# C, loaded with ctypes (hil/board/native.py); like the shim, no Python module init.
cyclehook = Extension(
    "hil.board._cyclehook",
    sources=["hil/board/cyclehook.c"],
    extra_compile_args=["-fvisibility=hidden", "-O2", "-Wall", "-Wextra"],
)
setup(ext_modules=[shim, cyclehook])
