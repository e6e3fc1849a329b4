"""Whether this install runs the device models and the plant compiled.

``pip install`` compiles ``emulators`` and ``hil.plant`` with mypyc (setup.py) unless the build
was told ``HIL_PURE_PYTHON=1`` or the Python had no C headers; their ``.py`` sources are the
reference either way (tests/system/test_compiled_equivalence.py). Runs record which one they
used (the MCAP's metadata) and ``hil perf`` prints it: the bench's CPU per tick depends on it.
"""

from __future__ import annotations

import importlib

#: one module per compiled package: each package is compiled whole or not at all
PROBES = {"emulators": "emulators.base", "hil.plant": "hil.plant.plant"}


def compiled() -> dict[str, bool]:
    """Package -> whether its modules are compiled extension modules here."""
    return {package: not str(importlib.import_module(module).__file__).endswith(".py")
            for package, module in PROBES.items()}


def describe() -> str:
    """One line for reports: ``compiled (mypyc)``, ``interpreted`` or the mix."""
    state = compiled()
    if all(state.values()):
        return "compiled (mypyc)"
    if not any(state.values()):
        return "interpreted (built with HIL_PURE_PYTHON=1 or without Python headers)"
    return ", ".join(f"{p} {'compiled' if c else 'interpreted'}" for p, c in state.items())
