"""Run directories: owner records and the sweep of directories whose owner is gone."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from hil.flight.rundir import OWNER_FILE, current_owner, make_run_dir, read_owner, sweep_stale


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _fake_run_dir(root: Path, name: str, owner: dict[str, object] | None) -> Path:
    d = root / name
    (d / "dev").mkdir(parents=True)
    (d / "dev" / "imu").symlink_to("/dev/pts/does-not-exist")  # dangling, as after SIGKILL
    (d / "flight.toml").write_text("")
    if owner is not None:
        (d / OWNER_FILE).write_text(json.dumps(owner))
    return d


def test_make_run_dir_is_private_and_owned(tmp_path: Path) -> None:
    d = make_run_dir("hil-test-", root=tmp_path)
    assert d.parent == tmp_path and d.name.startswith("hil-test-")
    assert (d.stat().st_mode & 0o777) == 0o700
    assert read_owner(d) == current_owner()


def test_sweep_removes_dirs_of_dead_owners_only(tmp_path: Path) -> None:
    me = current_owner()
    dead = _fake_run_dir(tmp_path, "hil-paper-quad-dead", {"pid": _dead_pid(), "start_ticks": 1})
    reused = _fake_run_dir(tmp_path, "hil-paper-quad-reused", {"pid": me.pid, "start_ticks": (me.start_ticks or 0) + 1})
    alive = _fake_run_dir(tmp_path, "hil-paper-quad-alive", {"pid": me.pid, "start_ticks": me.start_ticks})
    unowned = _fake_run_dir(tmp_path, "hil-paper-quad-unowned", None)  # being created, or not ours to judge
    garbled = _fake_run_dir(tmp_path, "hil-paper-quad-garbled", None)
    (garbled / OWNER_FILE).write_text("{not json")
    other = _fake_run_dir(tmp_path, "not-hil-dead", {"pid": _dead_pid(), "start_ticks": 1})

    removed = sweep_stale(tmp_path)

    assert sorted(removed) == sorted([dead, reused])
    assert not dead.exists() and not reused.exists()
    assert alive.exists() and unowned.exists() and garbled.exists() and other.exists()


def test_next_run_dir_sweeps_a_killed_bench(tmp_path: Path) -> None:
    """A bench killed with SIGKILL leaves its run dir; the next one removes it."""
    code = (
        "import os, sys; from pathlib import Path; from hil.flight.rundir import make_run_dir;"
        f"d = make_run_dir('hil-killed-', root=Path({str(tmp_path)!r})); (d / 'flight.toml').write_text('x');"
        "print(d, flush=True); os.kill(os.getpid(), 9)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == -9
    left = Path(proc.stdout.strip())
    assert left.is_dir()
    fresh = make_run_dir("hil-next-", root=tmp_path)
    assert not left.exists()
    assert fresh.exists()
    os.chmod(fresh, 0o700)
