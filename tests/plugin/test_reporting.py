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
