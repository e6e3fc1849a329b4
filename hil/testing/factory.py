"""The benches of one test (the ``hil_bench`` fixture's object): starts them, and at teardown
stops them, warns of event-loop stalls and keeps the MCAP logs of a failed test."""

from __future__ import annotations

import re
import shutil
import tempfile
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil.testing.records import HilBenchStallWarning
from hil.testing.scenario import build_scenario

if TYPE_CHECKING:
    from hil.live.topics import LiveConfig
    from hil.config.rig import Rig
    from hil.config.scenario import Scenario
    from hil.testing.bench import Bench


def _safe(text: str) -> str:
    """A test node id as a file name: path separators and odd characters replaced, at most 150 characters."""
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", text.replace("::", "--").replace("/", "-")).strip("_-")[:150]


class HilBench:
    """The ``hil_bench`` fixture: starts benches for one test, stops them at teardown."""

    def __init__(self, nodeid: str, name: str, *, keep_dir: Path, keep_all: bool = False,
                 require_virtual_time: bool = False,
                 live: LiveConfig | None = None) -> None:
        self.nodeid, self.name = nodeid, name
        self.live = live  #: --hil-live: every bench served to Foxglove (docs/live.md)
        self.keep_dir, self.keep_all = keep_dir, keep_all
        #: --hil-require-virtual-time: every bench's rig gets [flight] require_virtual_time = true
        self.require_virtual_time = require_virtual_time
        self.benches: list[Bench] = []
        self.kept: list[Path] = []
        self._tmp: Path | None = None

    async def start(self, rig: str | Path | Rig | None = None,
                    scenario: str | Path | Mapping[str, Any] | Scenario | None = None, *,
                    sticks: Sequence[Mapping[str, Any]] | None = None, flight: Mapping[str, Any] | None = None,
                    seed: int | None = None, duration_s: float | None = None, mode: str = "lockstep") -> Bench:
        """Start a run and return once its first tick (sim time 0) is done.

        ``rig``: name under rigs/ or path (None: the default rig); ``scenario``: see
        :func:`build_scenario` (None with ``sticks``: an inline scenario of
        ``duration_s`` or INLINE_DURATION_S); ``seed``: None = the scenario's; ``duration_s``:
        the run's sim length (None = the scenario's); ``mode``: "lockstep" or "realtime".
        """
        from hil.faults import load_faults
        from hil.config.rig import Rig, load_rig
        from hil.testing.bench import Bench  # the emulators' modules load with the first bench

        rig_obj = rig if isinstance(rig, Rig) else load_rig(rig)
        if self.require_virtual_time:
            import dataclasses

            rig_obj = dataclasses.replace(rig_obj, flight=dataclasses.replace(rig_obj.flight, require_virtual_time=True))
        scen, source = build_scenario(rig_obj, scenario, sticks=sticks, flight=flight, duration_s=duration_s,
                                      name=_safe(self.name))
        # as `hil run --duration` does: a shorter run keeps the scenario's later faults (unplayed)
        faults = load_faults(scen.faults, rig_obj, source=str(source or f"<scenario {scen.name}>"),
                             run_duration_s=scen.scenario.duration_s)
        if self._tmp is None:
            self._tmp = Path(tempfile.mkdtemp(prefix="hil-pytest-"))
        bench = Bench(rig_obj, scen, source=source, seed=seed, duration_s=duration_s, mode=mode,
                      log_path=self._tmp / f"{self._stem(len(self.benches))}.mcap", faults=faults)
        bench.live = self.live
        self.benches.append(bench)
        bench.log_path.parent.mkdir(parents=True, exist_ok=True)
        await bench._start()
        bench.log_event("test", {"nodeid": self.nodeid})
        return bench

    def _stem(self, i: int) -> str:
        return _safe(self.nodeid) + (f"-{i + 1}" if i else "")

    def keep_path(self, bench: Bench) -> Path:
        """Where the bench's MCAP goes if the test fails (or with --hil-keep-all)."""
        return self.keep_dir / f"{self._stem(self.benches.index(bench))}.mcap"

    def describe(self) -> str:
        lines: list[str] = []
        for b in self.benches:
            lines += [f"MCAP: {self.keep_path(b)}  (kept; finalized at teardown; `hil report` plots it)", b.describe()]
        return "\n".join(lines)

    async def aclose(self, failure: str | None) -> None:
        """Stop every bench (flight code stopped, MCAP finalized); keep the logs of a failed
        test (``failure`` = its report text) or all logs with keep_all; remove the rest."""
        errors: list[BaseException] = []
        for b in self.benches:
            try:
                if failure is not None:
                    b.log_event("test failed", {"nodeid": self.nodeid, "report": failure[-4000:]})
                b.torn_down = True
                b._gate_open.set()
                try:
                    log: Path | None = (await b.stop()).log_path
                except BaseException as exc:  # noqa: BLE001 - the run ended by an interrupt: its log is final
                    # or by an error the test was already given (a run that could not start)
                    task = b._task
                    raised = task is not None and task.done() and not task.cancelled() and task.exception() is exc
                    if exc is not b.interrupted and not raised:
                        raise
                    log = b.log_path
                if b.stalls:
                    worst = max(s for _, s in b.stalls)
                    warnings.warn(HilBenchStallWarning(
                        f"{self.nodeid}: the event loop did not run for up to {worst * 1e3:.0f} ms "
                        f"({len(b.stalls)} time(s)) while the bench ran, so the flight code's wall-clock IMU watchdog "
                        "may have fired: slow test code between awaits (do heavy work after bench.stop()), or an "
                        "overloaded machine"), stacklevel=1)
                if log is not None and log.exists() and (failure is not None or self.keep_all):
                    dest = self.keep_path(b)
                    dest.parent.mkdir(parents=True, exist_ok=True)
                    shutil.move(log, dest)
                    self.kept.append(dest)
            except BaseException as exc:  # noqa: BLE001 - stop the other benches first, then raise
                errors.append(exc)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
        if errors:
            raise errors[0]
