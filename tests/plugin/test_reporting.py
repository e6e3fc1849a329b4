"""The plugin as users get it (entry point, a pytest subprocess): pass/fail reporting, the
MCAP of a failing test kept and its path printed, everything else cleaned up."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from hil.record import iter_messages, read_metadata

pytest_plugins = ["pytester"]
pytestmark = [pytest.mark.system, pytest.mark.pty]

RIG = None  # the default rig

USER_TESTS = '''
import os
from pathlib import Path

import pytest

pytestmark = pytest.mark.asyncio
PIDS = Path(os.environ["HIL_PLUGIN_TEST_PIDS"])
RIG = {rig!r}


async def test_passes(hil_bench):
    bench = await hil_bench.start(rig=RIG, duration_s=5.0)
    (PIDS / "passes").write_text(str(bench.flight.pid))
    await bench.run_for(0.1)
    assert bench.truth.on_ground


async def test_fails(hil_bench):
    bench = await hil_bench.start(rig=RIG, duration_s=5.0)
    (PIDS / "fails").write_text(str(bench.flight.pid))
    async with bench.fault("telemetry.dropout"):
        await bench.run_for(0.1)
        assert bench.truth.h_m > 100.0, "the vehicle never left the ground"


def test_zz_flight_code_stopped():
    for name in ("passes", "fails"):
        pid = int((PIDS / name).read_text())
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
'''


def test_failing_test_keeps_its_mcap(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    sandbox = tmp_path / "tmp"  # the runs' temp dirs land here (TMPDIR) and must be gone after
    pids = tmp_path / "pids"
    sandbox.mkdir()
    pids.mkdir()
    monkeypatch.setenv("TMPDIR", str(sandbox))
    monkeypatch.setenv("HIL_PLUGIN_TEST_PIDS", str(pids))
    keep = tmp_path / "kept"
    pytester.makepyfile(test_user=USER_TESTS.format(rig=RIG))

    result = pytester.runpytest_subprocess("--hil-keep-logs", str(keep), "-p", "no:cacheprovider")

    result.assert_outcomes(passed=2, failed=1)
    kept = sorted(keep.iterdir())
    assert [p.name for p in kept] == ["test_user.py--test_fails.mcap"]
    log = kept[0]
    out = result.stdout.str()
    result.stdout.fnmatch_lines([
        "*- hil-bench -*",
        f"MCAP: {log}  (kept*",
        "rig paper-quad, scenario test_fails, seed 1: t = * s sim, running; now h = 0.000 m*",
        "*- hil-bench: MCAP logs kept -*",
        f"test_user.py::test_fails: {log}",
    ])
    assert "test_passes.mcap" not in out
    assert list(sandbox.iterdir()) == [], "run dirs or MCAP temp dirs left behind"

    # the kept log is finalized and says why the test failed
    assert read_metadata(log)["verdict"]["end_reason"] == "interrupted"
    events = [(m["kind"], m["name"], m["detail"]) for _, _, m in iter_messages(log, ["/hil/events"])]
    names = [(k, n) for k, n, _ in events]
    assert names.index(("fault", "telemetry.dropout start")) < names.index(("fault", "telemetry.dropout end"))
    failed = [d for k, n, d in events if (k, n) == ("pytest", "test failed")]
    assert len(failed) == 1 and failed[0]["nodeid"] == "test_user.py::test_fails"
    assert "the vehicle never left the ground" in failed[0]["report"]
    assert names.index(("pytest", "test failed")) < names.index(("pytest", "stop"))
    assert os.path.getsize(log) > 10_000


HANGING_TESTS = '''
import asyncio
import os
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.asyncio
PIDS = Path(os.environ["HIL_PLUGIN_TEST_PIDS"])


def _note(name, bench):
    (PIDS / name).write_text(f"{bench.flight.pid} {os.getpid()}")


@pytest.mark.timeout(20)
async def test_awaits_for_ever(hil_bench):
    bench = await hil_bench.start(duration_s=600.0)
    _note("awaits", bench)
    await asyncio.Event().wait()


@pytest.mark.timeout(20)
async def test_blocks_the_loop(hil_bench):
    bench = await hil_bench.start(duration_s=600.0)
    _note("blocks", bench)
    time.sleep(600)
'''


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (from /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


@pytest.mark.timeout(400)
def test_a_timed_out_test_never_hangs_its_teardown(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Path) -> None:
    """pytest-timeout ends a hanging test (awaiting for ever, or blocking the event loop):
    teardown stops the flight code and the recorder child, finalizes the MCAP and keeps it,
    and removes every temp dir; the session ends instead of hanging."""
    sandbox, pids, keep = tmp_path / "tmp", tmp_path / "pids", tmp_path / "kept"
    sandbox.mkdir()
    pids.mkdir()
    monkeypatch.setenv("TMPDIR", str(sandbox))
    monkeypatch.setenv("HIL_PLUGIN_TEST_PIDS", str(pids))
    pytester.makepyfile(test_user=HANGING_TESTS)

    # pytester's own timeout raises if the session hangs (what this test is about)
    result = pytester.runpytest_subprocess("--hil-keep-logs", str(keep), "-p", "no:cacheprovider",
                                           "-o", "timeout_method=signal", timeout=300)

    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(["*Timeout*"])
    kept = sorted(p.name for p in keep.iterdir())
    assert kept == ["test_user.py--test_awaits_for_ever.mcap", "test_user.py--test_blocks_the_loop.mcap"]
    for name in kept:
        assert read_metadata(keep / name)["verdict"]["end_reason"] == "interrupted"
    for name in ("awaits", "blocks"):
        flight_pid, session_pid = (int(x) for x in (pids / name).read_text().split())
        with pytest.raises(ProcessLookupError):
            os.kill(flight_pid, 0)
        assert _children(session_pid) == []  # the session is gone, and so are its children
    assert list(sandbox.iterdir()) == [], "run dirs or MCAP temp dirs left behind"
