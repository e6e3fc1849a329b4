"""Compiled parts of the bench, built by ``pip install`` on the machine (docs/performance.md).

- ``hil.vtime._shim``: the clock shim, a plain C shared library preloaded into the flight code
  in lockstep runs (docs/time.md). It has no Python module init and is never imported.
- The device models (``emulators``), the plant (``hil.plant``) and the bench's tick path
  (``TICK_PATH``: the tick loop, the device wiring, the virtual-time scheduler, the run
  logger and its streaming statistics, the pty port), compiled by mypyc from their Python sources. The
  sources stay the reference: the same modules run interpreted when the build is told
  ``HIL_PURE_PYTHON=1`` (``HIL_PURE_PYTHON=1 pip install -e .``), and
  tests/system/test_compiled_equivalence.py flies a flight both ways and compares them bit
  for bit.
  Pydantic-validated parameter modules stay interpreted: pydantic builds their validators at
  import time from the class bodies.
"""

from __future__ import annotations

import os
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup

ROOT = Path(__file__).parent
#: interpreted on purpose (see the module docstring)
INTERPRETED = {"params.py", "params_vehicle.py", "params_environment.py", "script.py"}
COMPILED_PACKAGES = ("emulators", "hil/plant")
#: the modules of ``hil`` a lockstep tick runs through (docs/performance.md, sixth round), and
#: the pty port under them (eighth round; the serial port, used only on attached hardware,
#: stays interpreted)
TICK_PATH = (
    "hil/flight/tickloop.py", "hil/flight/tick.py", "hil/flight/devices.py", "hil/flight/runlog.py",
    "hil/flight/messages.py", "hil/analysis/timing.py", "hil/analysis/timing_stream.py",
    "hil/analysis/online_stats.py",
    "hil/analysis/trace_stream.py", "hil/analysis/criteria_stream.py", "hil/analysis/signal_stream.py", "hil/flight/telemetry.py",
    "hil/frozen.py", "hil/record/process.py", "hil/vtime/control.py", "hil/vtime/scheduler.py",
    "hil/vtime/port_io.py", "hil/vtime/stall.py",
    "hil/transport/base.py", "hil/transport/pty.py",
)


def compiled_sources() -> list[str]:
    """The ``.py`` files mypyc compiles, relative to the project root, in a stable order."""
    files = []
    for package in COMPILED_PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.name not in INTERPRETED:
                files.append(path.relative_to(ROOT).as_posix())
    return files + list(TICK_PATH)


shim = Extension(
    "hil.vtime._shim",
    sources=["hil/vtime/shim.c"],
    depends=["hil/vtime/hvt_abi.h"],
    extra_compile_args=["-fvisibility=hidden", "-U_FORTIFY_SOURCE", "-O2", "-Wall", "-Wextra"],
    libraries=["dl"],
)


def compile_wanted() -> bool:
    """mypyc unless told otherwise, or unless this Python has no C headers (a distribution's
    Python without its -dev package): then the sources run interpreted, and we say so."""
    if os.environ.get("HIL_PURE_PYTHON", "") in ("1", "true", "yes"):
        return False
    headers = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not headers.exists():
        print(f"warning: {headers} is missing (install python3-dev): the device models and "
              "the plant run interpreted, about 1.3x the CPU per tick (docs/performance.md)", file=sys.stderr)
        return False
    return True


extensions = [shim]
if compile_wanted():
    from mypyc.build import mypycify

    # The build environment has numpy and pydantic for their types (pyproject.toml
    # [build-system]); --ignore-missing-imports covers anything else imported.
    extensions += mypycify(["--ignore-missing-imports", *compiled_sources()], opt_level="3",
                           group_name="hil_native")

setup(ext_modules=extensions)
