"""One campaign case on a worker that shares no filesystem with the client.

``run_bundled_case(case) -> dict`` is the unit of work of ``hil campaign`` for every executor
(process pool, local or remote Dask). The case carries its files as bytes
(hil/fleet/campaign_bundle.py); they are written to a temporary directory, the case runs
there as :func:`hil.fleet.campaign_case.run_case` (its own process), and the result goes
back with the bytes of the log it kept and, for a failed case, of its directory. The
temporary directory is removed whatever happens. A worker needs the installed package only.

The campaign's stop flag reaches the case in one of two ways: the campaign's ``STOP`` file
when the worker sees the campaign directory (the same machine, or a shared filesystem), and
the Dask event named ``stop_event`` (when the case runs on Dask), which a thread here turns
into a ``STOP`` file in the case's temporary directory.

``case`` keys: those of :func:`hil.fleet.campaign_case.run_case`'s params except the paths
(``case_id``, ``scenario_name``, ``seed``, ``mode``, ``duration_s``, ``flight_overrides``,
``rig_overrides``, ``keep_logs``, ``timeout_s``), plus ``files`` (relative path -> (mode,
bytes)), ``rig`` and ``scenario`` (their relative paths in ``files``), ``log_name``,
``stop_file`` (the campaign's, a client path) and ``stop_event`` (a Dask event name, or None).
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from hil import clock
from hil.fleet.campaign_bundle import WORK_DIR, materialize, pack_result
from hil.fleet.campaign_case import run_case

#: the prefix of every temporary directory a case runs in (tests check none is left)
TMP_PREFIX = "hil-case-"
#: how often the stop thread asks the Dask event
_STOP_POLL_S = 0.5


def _dask_event(name: str) -> Any:
    from distributed import Event

    return Event(name)


@contextlib.contextmanager
def stop_mirror(event_name: str | None, stop_file: Path) -> Iterator[None]:
    """Within: once the Dask event ``event_name`` is set, ``stop_file`` exists (checked once
    on entry, then every half second by a thread that ends on exit)."""
    if not event_name:
        yield
        return
    event = _dask_event(event_name)
    done = threading.Event()

    def watch() -> None:
        while not done.is_set():
            if event.wait(timeout=_STOP_POLL_S):
                stop_file.touch()
                return

    if event.is_set():
        stop_file.touch()
    thread = threading.Thread(target=watch, name="hil campaign stop", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join(timeout=5 * _STOP_POLL_S)


def _params(case: dict[str, Any], files: Path, root: Path, stop_file: Path) -> dict[str, Any]:
    keep = ("case_id", "scenario_name", "seed", "mode", "duration_s", "flight_overrides", "rig_overrides",
            "keep_logs", "timeout_s")
    return {**{k: case[k] for k in keep}, "rig": str(files / case["rig"]), "scenario": str(files / case["scenario"]),
            "case_dir": str(root / "case"), "log_path": str(root / "logs" / case["log_name"]),
            "stop_file": str(stop_file), "cwd": str(files / WORK_DIR), "tmpdir": str(root / "tmp")}


def run_bundled_case(case: dict[str, Any]) -> dict[str, Any]:
    """Materialize, run, pack: the case's result with its kept files as bytes."""
    t0 = clock.monotonic_ns()
    root = Path(tempfile.mkdtemp(prefix=TMP_PREFIX))
    try:
        files = root / "files"
        materialize(case["files"], files)
        (root / "tmp").mkdir()  # the case's TMPDIR: a killed bench's run directory goes with root
        campaign_stop = Path(case["stop_file"]) if case.get("stop_file") else None
        # the campaign's own flag where this machine sees its directory; else one of our own
        stop_file = campaign_stop if campaign_stop and campaign_stop.parent.is_dir() else root / "STOP"
        with stop_mirror(case.get("stop_event"), stop_file):
            result = run_case(_params(case, files, root, stop_file))
        result = pack_result(result)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    result["wall_s"] = (clock.monotonic_ns() - t0) / 1e9
    return result


__all__ = ["TMP_PREFIX", "run_bundled_case", "stop_mirror"]
