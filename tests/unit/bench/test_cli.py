"""Every `hil` command answers --help; bad input gets a clear error and exit status 2."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from hil.cli import app

runner = CliRunner()
COMMANDS = sorted(c.name or c.callback.__name__ for c in app.registered_commands)  # type: ignore[union-attr]


def test_every_expected_command_exists() -> None:
    assert {"run", "devices", "faults", "timing", "report", "replay", "recover", "campaign", "perf"} <= set(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_help(command: str) -> None:
    result = runner.invoke(app, [command, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output


def test_unknown_rig_is_a_clear_error() -> None:
    result = runner.invoke(app, ["run", "no-such-rig"])
    assert result.exit_code == 2
    assert "no-such-rig" in result.output and "no such rig" in result.output


def test_unknown_scenario_lists_the_known_ones() -> None:
    result = runner.invoke(app, ["run", "-s", "no-such-scenario"])
    assert result.exit_code == 2
    assert "hover" in result.output


def test_bad_mode_is_refused() -> None:
    result = runner.invoke(app, ["run", "--mode", "fast"])
    assert result.exit_code == 2
    assert "lockstep" in result.output


def test_faults_lists_the_catalogue() -> None:
    result = runner.invoke(app, ["faults"])
    assert result.exit_code == 0
    assert "imu.silence" in result.output and "wire.bit_flips" in result.output


def test_mode_names_match_the_bench() -> None:
    from hil.flight.tickloop import Mode
    from hil.cli import _MODES

    assert tuple(m.value for m in Mode) == _MODES


_HEAVY = ("matplotlib", "dask", "distributed", "scipy", "control", "jsonschema", "google.protobuf")


def _after_cli(argv: list[str], expression: str) -> tuple[str, str, str]:
    """Run ``hil <argv>`` in a fresh interpreter, then print ``expression`` there: (its
    value, the whole stdout, stderr)."""
    import subprocess
    import sys

    code = ("import sys\nfrom hil.cli import app\ntry:\n    app(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            f"print({expression})")
    out = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    return out.stdout.strip().splitlines()[-1], out.stdout, out.stderr


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["run", "--mode", "fast"], ["run", "no-such-rig"],
                                  ["timing", "no-such.mcap"], ["report", "no-such.mcap"], ["replay", "no-such.mcap"],
                                  ["recover", "no-such.mcap"], ["campaign", "no-such.toml"], ["perf", "--help"]])
def test_help_and_argument_errors_import_nothing_heavy(argv: list[str]) -> None:
    # start-up time of `hil` (issue 12): heavy packages only where a command uses them
    last, stdout, stderr = _after_cli(
        argv, f"sorted(m for m in sys.modules if m.split('.')[0] in {_HEAVY!r} or m in {_HEAVY!r})")
    assert last == "[]", (stdout, stderr)


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["perf", "--help"], ["campaign", "--help"]])
def test_help_does_not_import_asyncio(argv: list[str]) -> None:
    # a third of `hil.cli`'s own import time was asyncio, which only the commands that run use
    last, stdout, stderr = _after_cli(argv, "'asyncio' in sys.modules")
    assert last == "False", (stdout, stderr)
