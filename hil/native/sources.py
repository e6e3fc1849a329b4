"""Which sources the compiled build (``hil build``) compiles, and which it watches.

mypyc compiles the device models (``emulators``), the plant (``hil.plant``) and the modules of
``hil`` a lockstep tick runs through (``TICK_PATH``). The ``.py`` files stay the reference: an
install runs them interpreted until ``hil build`` compiles them, and
tests/system/test_compiled_equivalence.py flies a flight both ways and compares them bit for bit.

A build is fresh while every watched source is the one it compiled. mypyc type-checks the
compiled modules against everything they import, so the watched set is every ``.py`` of
``emulators`` and ``hil``, not only the compiled ones: an edit to any of them can change what
the compiled code should be.
"""

from __future__ import annotations

import enum
from pathlib import Path

#: interpreted on purpose: pydantic builds their validators at import time from the class
#: bodies; ``script.py`` holds the scenario's stick scripts, built once per run
INTERPRETED = frozenset({"params.py", "params_vehicle.py", "params_environment.py", "script.py"})
COMPILED_PACKAGES = ("emulators", "hil/plant")
#: the modules of ``hil`` a lockstep tick runs through, and the pty port under them (the serial
#: port, used only on attached hardware, stays interpreted)
TICK_PATH = (
    "hil/flight/tickloop.py", "hil/flight/tick.py", "hil/flight/devices.py", "hil/flight/runlog.py",
    "hil/flight/messages.py", "hil/analysis/timing.py", "hil/analysis/timing_stream.py",
    "hil/analysis/online_stats.py", "hil/analysis/trace_stream.py", "hil/analysis/criteria_stream.py",
    "hil/analysis/signal_stream.py", "hil/flight/telemetry.py", "hil/native/frozen.py", "hil/record/process.py",
    "hil/vtime/control.py", "hil/vtime/scheduler.py", "hil/vtime/port_io.py", "hil/vtime/stall.py",
    "hil/transport/base.py", "hil/transport/pty.py",
)
#: the packages whose sources a build watches
WATCHED_PACKAGES = ("emulators", "hil")


def project_root() -> Path:
    """The directory holding the ``hil`` and ``emulators`` packages (the checkout)."""
    return Path(__file__).resolve().parents[2]


def compiled_sources(root: Path) -> list[str]:
    """The ``.py`` files mypyc compiles, relative to ``root``, in a stable order."""
    files = [path.relative_to(root).as_posix()
             for package in COMPILED_PACKAGES for path in sorted((root / package).rglob("*.py"))
             if path.name not in INTERPRETED]
    return files + [p for p in TICK_PATH if (root / p).exists()]


def watched_sources(root: Path) -> list[str]:
    """Every ``.py`` file of the watched packages, relative to ``root``, sorted."""
    return sorted(path.relative_to(root).as_posix()
                  for package in WATCHED_PACKAGES for path in (root / package).rglob("*.py"))


def module_name(source: str) -> str:
    """``hil/plant/plant.py`` -> ``hil.plant.plant``; ``emulators/rc/__init__.py`` -> ``emulators.rc``."""
    parts = source.removesuffix(".py").split("/")
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


#: ``hil build --groups``: how the compiled sources are split into mypyc groups. A group is one
#: C file, compiled by one core; calls between modules of one group stay inside that file.
#: ``modules``: one group per module, compiled in parallel at -O2 (the default, ~2 min);
#: ``one``: every module in one group at -O3, the old build (5-9 min on one core), the fastest
#: ticks. Grouping only the plant and the tick path at -O3 was measured too and left out: its
#: group is half the C, and it stays slower than ``one`` (docs/performance.md, Builds)
class Grouping(str, enum.Enum):
    MODULES = "modules"
    ONE = "one"


GROUPINGS = tuple(g.value for g in Grouping)
OPT_LEVELS = {"modules": "2", "one": "3"}
#: the name of the one group's shared library (``hil_native__mypyc``), as the old build had it
ONE_GROUP = "hil_native"


def groups(sources: list[str], grouping: str) -> list[tuple[list[str], str | None]]:
    """mypycify's ``separate``: the groups of ``sources`` (paths) for ``grouping``; a group
    named None is named by mypyc after its modules."""
    if grouping == "modules":
        return [([source], None) for source in sources]
    if grouping == "one":
        return [(list(sources), ONE_GROUP)]
    raise ValueError(f"grouping {grouping!r}: expected one of {', '.join(GROUPINGS)}")
