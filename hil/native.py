"""Whether this install runs the device models, the plant and the tick path compiled.

``pip install`` compiles ``emulators``, ``hil.plant`` and the modules of ``hil`` on the tick
path with mypyc (setup.py) unless the build
was told ``HIL_PURE_PYTHON=1`` or the Python had no C headers; their ``.py`` sources are the
reference either way (tests/system/test_compiled_equivalence.py). Runs record which one they
used (the MCAP's metadata) and ``hil perf`` prints it: the bench's CPU per tick depends on it.
"""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path

#: one module per compiled part: each part is compiled whole or not at all
PROBES = {"emulators": "emulators.base", "hil.plant": "hil.plant.plant", "hil tick path": "hil.flight.devices"}


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


def built_at() -> float | None:
    """When the compiled code was built (its shared library's mtime, s), None if it is not."""
    spec = importlib.util.find_spec("hil_native__mypyc")
    return None if spec is None or spec.origin is None else Path(spec.origin).stat().st_mtime


def stale(built: float | None = None) -> list[Path]:
    """The sources of compiled modules that changed after the build (an edit, a ``git pull``):
    until ``pip install -e .`` rebuilds, Python keeps running the old compiled code, not
    them. Empty when nothing is compiled. ``built``: the build's time (default: ``built_at()``)."""
    built = built_at() if built is None else built
    if built is None:
        return []
    # the top-level package of each compiled part, walked once
    roots = {Path(str(importlib.import_module(PROBES[part].split(".")[0]).__file__)).parent
             for part, is_compiled in compiled().items() if is_compiled}
    # a compiled module is ``<stem>.<abi tag>.so`` beside its ``<stem>.py``
    sources = sorted({so.with_name(so.name.split(".")[0] + ".py") for root in roots for so in root.rglob("*.so")})
    return [p for p in sources if p.exists() and p.stat().st_mtime > built]


def stale_message(sources: list[Path]) -> str:
    names = ", ".join(str(p) for p in sources[:3]) + (f" and {len(sources) - 3} more" if len(sources) > 3 else "")
    return (f"{names} changed after the compiled modules were built: Python runs the old "
            "compiled code. Rebuild with `pip install -e .` (HIL_PURE_PYTHON=1 to keep them "
            "interpreted while you work on them).")
