"""`hil run` as a new user meets it: piped output, a refused scenario, leftovers."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _hil(args: list[str], tmp: Path, timeout_s: float = 120) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, TMPDIR=str(tmp), COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "hil.cli", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout_s)


def test_fault_after_the_end_is_an_error_and_creates_nothing(tmp_path: Path) -> None:
    scen = tmp_path / "late.toml"
    scen.write_text(
        '[scenario]\nname = "late"\ndescription = "a fault after the end"\nduration_s = 2.0\nseed = 1\n\n'
        '[[faults]]\nkind = "imu.silence"\nt_s = 5.0\nduration_s = 1.0\n'
    )
    runs = tmp_path / "tmp"
    runs.mkdir()
    logs = tmp_path / "logs"
    proc = _hil(["run", "-s", str(scen), "--out", str(logs)], runs)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: "), proc.stderr
    assert f"{scen}: [[faults]] #0 (imu.silence) t_s: 5 s is not before the end of the run (2 s)" in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    assert list(runs.iterdir()) == []
    assert not logs.exists()


@pytest.mark.system
def test_piped_run_prints_plain_progress_lines(tmp_path: Path) -> None:
    proc = _hil(["run", "-s", "hover", "--duration", "1.5", "--no-record"], tmp_path)
    assert proc.returncode in (0, 1), proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("paper-quad/hover: sim    0.00/1.5 s (  0%)  RTF -  phase: arm"), proc.stdout
    assert any(line.startswith("paper-quad/hover: sim ") and "phase: arm" in line for line in lines), proc.stdout
    assert "\x1b[" not in proc.stdout  # no cursor movement or colour codes in a log
    assert [p for p in tmp_path.iterdir() if p.name.startswith("hil-")] == []
