"""A run always ends cleanly with a finalized, readable log: flight-code crash, Ctrl-C,
boot failure; and a killed bench's file is recoverable."""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hil.flight.tickloop import EndReason
from hil.record import TornRecordingError, message_counts, read_metadata, read_topic
from tests.system.conftest import explain, rig_with_command

pytestmark = [pytest.mark.system, pytest.mark.pty]
ROOT = Path(__file__).resolve().parents[2]


async def test_flight_code_crash_ends_the_run_with_its_status(fly, tmp_path: Path) -> None:
    rig = rig_with_command(tmp_path, ["{python}", str(ROOT / "tests" / "system" / "crashing_flight.py"), "{config}"], "crash-rig")
    result = await fly("hover", rig=str(rig))
    assert result.end_reason is EndReason.FLIGHT_EXITED, explain(result)
    assert result.flight_returncode == 7
    assert any("simulated crash" in line for line in result.flight_stderr_tail)
    assert not result.passed
    assert result.log_path is not None
    meta = read_metadata(result.log_path)
    assert meta["verdict"]["end_reason"] == "flight code exited"
    assert meta["verdict"]["flight_returncode"] == "7"
    assert message_counts(result.log_path)["/hil/verdict"] == 1


async def test_flight_code_that_never_configures_fails_boot_naming_the_device(fly, tmp_path: Path) -> None:
    # A "flight code" that opens nothing and waits: the bench must give up and say which device.
    rig = rig_with_command(tmp_path, ["{python}", "-c", "import time; time.sleep(60)"], "crash-rig")
    text = rig.read_text().replace("boot_timeout_s = 20.0", "boot_timeout_s = 1.0")
    rig.write_text(text)
    result = await fly("hover", rig=str(rig))
    assert result.end_reason is EndReason.BOOT_FAILED
    assert "imu" in result.message and "adc" in result.message
    assert result.log_path is not None and read_metadata(result.log_path)["verdict"]["end_reason"] == "boot failed"


def _start_cli_run(tmp_path: Path, *extra: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "hil.cli", "run", "-s", "hover", "--out", str(tmp_path), "-q", *extra],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )


async def _wait_for(predicate, timeout_s: float = 60.0) -> None:
    """Poll a condition of the file system (the run's progress), bounded."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate():
        assert loop.time() < deadline, "condition not reached in time"
        await asyncio.sleep(0.05)


def _ticks_recorded(tmp_path: Path, min_bytes: int) -> bool:
    parts = list(tmp_path.glob("*.mcap.part"))
    return bool(parts) and parts[0].stat().st_size >= min_bytes


async def test_ctrl_c_finalizes_the_log(tmp_path: Path) -> None:
    proc = _start_cli_run(tmp_path)
    try:
        await _wait_for(lambda: _ticks_recorded(tmp_path, 150_000))
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, out.decode()
    logs = list(tmp_path.glob("*.mcap"))
    assert len(logs) == 1 and not list(tmp_path.glob("*.part")), out.decode()
    assert read_metadata(logs[0])["verdict"]["end_reason"] == "interrupted"
    assert read_topic(logs[0], "/sim/truth")["h_m"].size > 100
    assert b"interrupted" in out


async def test_killed_run_is_recoverable(tmp_path: Path) -> None:
    proc = _start_cli_run(tmp_path)
    try:
        await _wait_for(lambda: _ticks_recorded(tmp_path, 400_000))
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    parts = list(tmp_path.glob("*.mcap.part"))
    if not parts:
        # The kernel closes a dying process's files before it sends the children their
        # PR_SET_PDEATHSIG signal: the recorder child can see its pipe close first and
        # finish the file, marked aborted, before the signal comes (seen beside four CPU
        # hogs). Nothing is lost then, and there is nothing to recover.
        (done,) = tmp_path.glob("*.mcap")
        assert read_metadata(done)["verdict"]["status"] == "aborted"
        assert "closed the pipe" in read_metadata(done)["verdict"]["error"]
        assert sum(message_counts(done).values()) > 1000
        assert read_topic(done, "/sim/truth")["h_m"].size > 100
        return
    (part,) = parts
    try:
        message_counts(part)
    except TornRecordingError:
        pass  # the usual case: the recorder child died with the bench, mid-chunk
    else:
        # as above, but the signal came between the file's end and its rename
        assert read_metadata(part)["verdict"]["status"] == "aborted"
    out = tmp_path / "recovered.mcap"
    cli = subprocess.run(
        [sys.executable, "-m", "hil.cli", "recover", str(part), "--out", str(out)], cwd=ROOT, capture_output=True, text=True
    )
    assert cli.returncode == 0, cli.stderr
    n = sum(message_counts(out).values())
    assert n > 1000
    assert read_metadata(out)["run"]["scenario"] == "hover"
    assert read_topic(out, "/sim/truth")["h_m"].size > 100
