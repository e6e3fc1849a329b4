"""``--require-virtual-time``, the rig's ``[flight] require_virtual_time`` and the plugin's
``--hil-require-virtual-time`` turn lockstep's fall-back to the host clock into an error
naming the reason: the clock shim missing (at start), LD_PRELOAD dropped (during boot)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from typer.testing import CliRunner

import hil.vtime.session
from hil.cli import app
from hil.config.rig import load_rig
from hil.flight.run import VirtualTimeRequired
from hil.record import read_metadata
from hil.vtime.preload import Fallback

pytest_plugins = ["pytester"]
pytestmark = [pytest.mark.system, pytest.mark.pty]
ROOT = Path(__file__).resolve().parents[2]
NO_SHIM = "the clock shim was not built (forced by the test)"


@pytest.fixture
def no_shim(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(hil.vtime.session, "shim_library", lambda: Fallback(NO_SHIM))


def _dropping_rig(tmp_path: Path, *, required: bool) -> Path:
    """The default rig, its flight code started through ``env -u LD_PRELOAD`` (the shim is lost)."""
    text = (ROOT / "rigs" / "paper-quad.toml").read_text()
    text = text.replace('command = ["{python}"', 'command = ["env", "-u", "LD_PRELOAD", "{python}"', 1)
    text = text.replace('config = "flightcode-paper-quad.toml"', f'config = "{ROOT / "rigs" / "flightcode-paper-quad.toml"}"')
    if required:
        text = text.replace("[flight]\n", "[flight]\nrequire_virtual_time = true\n", 1)
    rig = tmp_path / "dropping.toml"
    rig.write_text(text)
    (tmp_path / "scenarios").mkdir(exist_ok=True)
    (tmp_path / "scenarios" / "hover.toml").write_text((ROOT / "rigs" / "scenarios" / "hover.toml").read_text())
    return rig


async def test_a_missing_shim_is_an_error_when_required(fly, no_shim, tmp_path: Path) -> None:
    with pytest.raises(VirtualTimeRequired, match="virtual time is required.*forced by the test"):
        await fly("hover", duration_s=0.2, require_virtual_time=True)
    assert not list(tmp_path.glob("*.part"))


async def test_a_missing_shim_is_a_note_otherwise(fly, no_shim) -> None:
    result = await fly("hover", duration_s=0.2)
    assert NO_SHIM in result.clock_note


async def test_a_dropped_preload_is_an_error_when_the_rig_requires_it(fly, tmp_path: Path) -> None:
    rig = load_rig(_dropping_rig(tmp_path, required=True))
    assert rig.flight.require_virtual_time
    with pytest.raises(VirtualTimeRequired, match="runs without the clock shim"):
        await fly("hover", rig=rig, duration_s=0.5)
    [log] = tmp_path.glob("*.mcap")  # the run had started: its log is finalized, and says why
    verdict = read_metadata(log)["verdict"]
    assert verdict["end_reason"] == "bench error" and "virtual time is required" in verdict["message"]


def test_hil_run_require_virtual_time_exits_2(no_shim, tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", "-s", "hover", "--duration", "0.2", "--out", str(tmp_path), "-q",
                                   "--require-virtual-time"], env={"COLUMNS": "300"})
    assert res.exit_code == 2, res.output
    assert "error: virtual time is required" in res.output and NO_SHIM in res.output
    assert "Traceback" not in res.output


def test_hil_run_on_a_rig_that_requires_it_exits_2(tmp_path: Path) -> None:
    rig = _dropping_rig(tmp_path, required=True)
    res = CliRunner().invoke(app, ["run", str(rig), "-s", "hover", "--duration", "0.5", "--out", str(tmp_path / "logs"),
                                   "-q"], env={"COLUMNS": "300"})
    assert res.exit_code == 2, res.output
    assert "virtual time is required" in res.output and "runs without the clock shim" in res.output


def test_the_plugin_option_makes_the_fallback_an_error(pytester: pytest.Pytester, tmp_path: Path) -> None:
    rig = _dropping_rig(tmp_path, required=False)
    pytester.makepyfile(test_user=f'''
import pytest

pytestmark = pytest.mark.asyncio


async def test_flies(hil_bench):
    bench = await hil_bench.start(rig={str(rig)!r}, scenario="hover", duration_s=0.5)
    await bench.run_for(0.1)
''')
    plain = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    plain.assert_outcomes(passed=1)
    strict = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--hil-require-virtual-time")
    strict.assert_outcomes(failed=1)
    strict.stdout.fnmatch_lines(["*VirtualTimeRequired: virtual time is required*"])
