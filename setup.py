"""Compiled parts of the bench, built by ``pip install`` on the machine (docs/performance.md).

- ``hil.vtime._shim``: the clock shim, a plain C shared library preloaded into the flight code
  in lockstep runs (docs/time.md). It has no Python module init and is never imported.
- The device models (``emulators``) and the plant (``hil.plant``), compiled by mypyc from
  their Python sources. The sources stay the reference: the same modules run interpreted
  when the build is told ``HIL_PURE_PYTHON=1`` (``HIL_PURE_PYTHON=1 pip install -e .``), and
  tests/unit/bench/test_compiled.py runs a flight both ways and compares them bit for bit.
  Pydantic-validated parameter modules stay interpreted: pydantic builds their validators at
  import time from the class bodies.
"""

from __future__ import annotations

import os
from pathlib import Path

from setuptools import Extension, setup

ROOT = Path(__file__).parent
#: interpreted on purpose (see the module docstring)
INTERPRETED = {"params.py", "script.py"}
COMPILED_PACKAGES = ("emulators", "hil/plant")


def compiled_sources() -> list[str]:
    """The ``.py`` files mypyc compiles, relative to the project root, in a stable order."""
    files = []
    for package in COMPILED_PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.name not in INTERPRETED:
                files.append(path.relative_to(ROOT).as_posix())
    return files


shim = Extension(
    "hil.vtime._shim",
    sources=["hil/vtime/shim.c"],
    depends=["hil/vtime/hvt_abi.h"],
    extra_compile_args=["-fvisibility=hidden", "-U_FORTIFY_SOURCE", "-O2", "-Wall", "-Wextra"],
    libraries=["dl"],
)

extensions = [shim]
if os.environ.get("HIL_PURE_PYTHON", "") not in ("1", "true", "yes"):
    from mypyc.build import mypycify

    # The build environment has numpy and pydantic for their types (pyproject.toml
    # [build-system]); --ignore-missing-imports covers anything else imported.
    extensions += mypycify(["--ignore-missing-imports", *compiled_sources()], opt_level="3",
                           group_name="hil_native")

setup(ext_modules=extensions)
