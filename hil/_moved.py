"""Import paths that moved when ``hil/`` was laid out by job (docs/architecture.md), kept
working for a while with a :class:`DeprecationWarning` naming the new path.

``import hil.replay`` or ``from hil.campaign import run_campaign`` gives the module at its new
path itself (``hil.replay is hil.fleet.replay``), so a name patched through either path is
patched for both. A finder on ``sys.meta_path`` answers only for the names in :data:`MOVED`.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings
from collections.abc import Sequence
from pathlib import Path

#: old module path -> new module path
MOVED: dict[str, str] = {
    "hil.rig": "hil.config.rig",
    "hil.scenario": "hil.config.scenario",
    "hil.attach": "hil.config.attach",
    "hil.run": "hil.flight.run",
    "hil.bench": "hil.flight.tickloop",
    "hil.devices": "hil.flight.devices",
    "hil.flightproc": "hil.flight.process",
    "hil.scenario_runner": "hil.flight.scenario_runner",
    "hil.stress": "hil.flight.stress",
    "hil.runlog": "hil.flight.runlog",
    "hil.telemetry": "hil.flight.telemetry",
    "hil.rundir": "hil.flight.rundir",
    "hil.devices_cmd": "hil.flight.devices_live",
    "hil.progress": "hil.flight.progress",
    "hil.trace": "hil.analysis.trace",
    "hil.trace_stream": "hil.analysis.trace_stream",
    "hil.signal_stream": "hil.analysis.signal_stream",
    "hil.online_stats": "hil.analysis.online_stats",
    "hil.criteria": "hil.analysis.criteria",
    "hil.criteria_stream": "hil.analysis.criteria_stream",
    "hil.timing": "hil.analysis.timing",
    "hil.summary": "hil.analysis.summary",
    "hil.report": "hil.analysis.report",
    "hil.campaign": "hil.fleet.campaign",
    "hil.campaign_case": "hil.fleet.campaign_case",
    "hil.replay": "hil.fleet.replay",
    "hil.fidelity": "hil.fleet.fidelity",
    "hil.rtsched": "hil.host.rtsched",
    "hil.cpulatency": "hil.host.cpulatency",
    "hil.steal": "hil.host.steal",
    "hil.hostnoise": "hil.host.hostnoise",
    "hil.cpuuse": "hil.host.cpuuse",
    "hil.procstat": "hil.host.procstat",
    "hil.perf": "hil.host.perf",
    "hil.skeleton": "hil.host.skeleton",
}

_IMPORTLIB_DIR = str(Path(importlib.__file__).parent)


def _importer_stacklevel() -> int:
    """The ``stacklevel`` that points the warning at the line that imported the old path: past
    this module and ``importlib``'s own frames (``import_module``). ``warnings`` itself skips
    the import system's bootstrap frames and does not count them."""
    level, frame = 1, sys._getframe(2)  # 1: exec_module, the caller of warnings.warn
    while frame is not None:
        name = frame.f_code.co_filename
        if "importlib" in name and "_bootstrap" in name:
            pass  # not counted by warnings
        elif name.startswith(_IMPORTLIB_DIR):
            level += 1
        else:
            return level + 1
        frame = frame.f_back  # type: ignore[assignment]
    return level


class _MovedLoader(importlib.abc.Loader):
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None  # a placeholder module; exec_module puts the real one in its place

    def exec_module(self, module: types.ModuleType) -> None:
        warnings.warn(f"{module.__name__} moved to {self.new}; import it from there "
                      "(docs/architecture.md)", DeprecationWarning,
                      stacklevel=_importer_stacklevel())
        # the import system returns whatever sys.modules holds under the name after this
        sys.modules[module.__name__] = importlib.import_module(self.new)


class MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old paths of :data:`MOVED`, and nothing else."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: types.ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        new = MOVED.get(fullname)
        return None if new is None else importlib.machinery.ModuleSpec(fullname, _MovedLoader(new))


def install() -> None:
    """Put the finder on ``sys.meta_path`` once (``hil/__init__.py`` calls it)."""
    if not any(isinstance(f, MovedFinder) for f in sys.meta_path):
        sys.meta_path.append(MovedFinder())
