"""Run directories: private temp dirs with an owner record, and the sweep of stale ones.

A run directory (``<tmp>/hil-<rig>-XXXX``, mode 0700) holds the device symlinks and the
flight code's config for one bench process. A bench killed with SIGKILL cannot remove it,
so every directory carries ``owner.json`` (pid and the process's start time in clock
ticks since boot, which tells a live owner from a reused pid), and the next bench removes
the directories whose owner is gone. Directories without an owner record (another tool,
an older bench, or one being created right now) are never touched.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat as stat_mod
import tempfile
from dataclasses import dataclass
from pathlib import Path

from hil.host.procstat import STARTTIME, stat_fields

OWNER_FILE = "owner.json"
PREFIX = "hil-"


@dataclass(frozen=True)
class Owner:
    """The process that owns a run directory: pid and its start time (clock ticks after boot)."""

    pid: int
    start_ticks: int | None


def _start_ticks(pid: int) -> int | None:
    """Field 22 of /proc/<pid>/stat (starttime), None if the process does not exist."""
    fields = stat_fields(pid)
    return None if fields is None else int(fields[STARTTIME])


def current_owner() -> Owner:
    return Owner(os.getpid(), _start_ticks(os.getpid()))


def owner_alive(owner: Owner) -> bool:
    """True while the recorded process still runs (same pid and same start time)."""
    try:
        os.kill(owner.pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # exists, belongs to someone else
    ticks = _start_ticks(owner.pid)
    if ticks is None:
        return False
    return owner.start_ticks is None or ticks == owner.start_ticks


def read_owner(run_dir: Path) -> Owner | None:
    """The owner record of ``run_dir``, None if it has none or it is unreadable."""
    try:
        raw = json.loads((run_dir / OWNER_FILE).read_text())
        return Owner(int(raw["pid"]), None if raw.get("start_ticks") is None else int(raw["start_ticks"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def sweep_stale(root: Path | None = None) -> list[Path]:
    """Remove this user's ``hil-*`` run directories in ``root`` (default: the temp dir)
    whose owner process is gone; returns what was removed."""
    root = Path(root or tempfile.gettempdir())
    removed: list[Path] = []
    uid = os.getuid()
    try:
        entries = list(root.iterdir())
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(PREFIX):
            continue
        try:
            st = entry.lstat()
        except OSError:
            continue
        if not stat_mod.S_ISDIR(st.st_mode) or st.st_uid != uid:
            continue
        owner = read_owner(entry)
        if owner is None or owner_alive(owner):
            continue
        shutil.rmtree(entry, ignore_errors=True)
        if not entry.exists():
            removed.append(entry)
    return removed


def make_run_dir(prefix: str, root: Path | None = None) -> Path:
    """Sweep stale run dirs, then create a new private (0700) one owned by this process."""
    if not prefix.startswith(PREFIX):
        raise ValueError(f"run dir prefix must start with {PREFIX!r}: {prefix!r}")
    with contextlib.suppress(OSError):
        sweep_stale(root)
    run_dir = Path(tempfile.mkdtemp(prefix=prefix, dir=root))
    os.chmod(run_dir, 0o700)
    owner = current_owner()
    (run_dir / OWNER_FILE).write_text(json.dumps({"pid": owner.pid, "start_ticks": owner.start_ticks}))
    return run_dir
