"""Whether this process runs the device models, the plant and the tick path compiled.

An install runs every module from its ``.py`` source. ``hil build`` compiles the device models
(``emulators``), the plant (``hil.plant``) and the modules of ``hil`` on the tick path with mypyc
into a build directory of the environment (hil/native/build.py); from then on, ``import hil``
loads them compiled as long as the build is the build of the sources on disk
(hil/native/loader.py). The sources are the reference either way
(tests/system/test_compiled_equivalence.py). Runs record which way they ran (the MCAP's
metadata) and ``hil run`` and ``hil perf`` print it: the bench's CPU per tick depends on it.
"""

from __future__ import annotations

import datetime
import importlib

from hil.native.loader import LOADER, LoadState, Why, build_dir, rebuild_command, stale_message

__all__ = ["LoadState", "Why", "build_dir", "compiled", "describe", "install",
           "stale", "stale_message", "state"]

#: one module per compiled part: each part is compiled whole or not at all
PROBES = {"emulators": "emulators.base", "hil.plant": "hil.plant.plant", "hil tick path": "hil.flight.devices"}


def install() -> LoadState:
    """Decide, once per process, whether to load the compiled build (``import hil`` does)."""
    return LOADER.install()


def state() -> LoadState:
    return LOADER.state


def compiled() -> dict[str, bool]:
    """Part -> whether its modules are compiled extension modules in this process."""
    return {part: not str(importlib.import_module(module).__file__).endswith(".py")
            for part, module in PROBES.items()}


def stale() -> list[str]:
    """The sources edited since the compiled build (relative to the checkout); empty when the
    build is fresh or there is none. While it is not empty, everything runs interpreted."""
    return list(state().changed)


def describe() -> str:
    """One line for summaries and logs: which way this process runs, and why."""
    s = state()
    if s.why is Why.COMPILED:
        built = datetime.datetime.fromtimestamp(s.built_ns / 1e9, tz=datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
        grouping = "one extension per module" if s.groups == "modules" else f"--groups {s.groups}"
        return f"compiled (mypyc -O{s.opt_level}, {grouping}, built {built})"
    reasons = {
        Why.NOT_BUILT: "no compiled build: `hil build` compiles one",
        Why.SWITCHED_OFF: s.detail,
        Why.STALE: f"the compiled build is stale ({len(s.changed)} sources changed): `{rebuild_command(s.groups)}`",
        Why.OTHER_BUILD: f"the compiled build is for {s.detail}: `hil build`",
        Why.UNREADABLE: f"the compiled build is unreadable ({s.detail}): `hil build`",
        Why.IMPORTED_FIRST: f"{s.detail} imported before hil",
    }
    return f"interpreted ({reasons[s.why]})"
