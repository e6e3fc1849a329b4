"""Every command states its exit statuses; the README's everyday commands work as printed."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hil.cli import app

REPO = Path(__file__).resolve().parents[3]
COMMANDS = sorted(c.name or c.callback.__name__ for c in app.registered_commands)  # type: ignore[union-attr]
#: command groups (`hil firmware build`)
GROUPS = sorted(str(g.name) for g in app.registered_groups)


def test_commands_known() -> None:
    assert set(COMMANDS) >= {"run", "devices", "report", "timing", "replay", "recover", "campaign", "perf", "faults"}


@pytest.mark.parametrize("command", COMMANDS)
def test_help_states_exit_statuses(command: str) -> None:
    res = CliRunner().invoke(app, [command, "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    assert "Exit status: 0" in res.output, res.output


def test_top_level_help_states_exit_statuses() -> None:
    res = CliRunner().invoke(app, ["--help"], env={"COLUMNS": "200"})
    assert "Exit status of every command: 0 success, 1" in res.output


@pytest.mark.parametrize("command", ["report", "timing", "recover", "replay"])
def test_missing_log_is_error_rc2(command: str, tmp_path: Path) -> None:
    res = CliRunner().invoke(app, [command, str(tmp_path / "nope.mcap")])
    assert res.exit_code == 2
    assert "error:" in res.output and "nope.mcap: no such file" in res.output


def _everyday_block() -> list[str]:
    text = (REPO / "README.md").read_text()
    block = text.split("## Everyday use", 1)[1].split("```sh\n", 1)[1].split("```", 1)[0]
    return [line.split("#", 1)[0].strip() for line in block.splitlines() if line.strip()]


def test_readme_everyday_commands_name_real_commands() -> None:
    lines = _everyday_block()
    assert lines[0] == ". .venv/bin/activate"
    for line in lines[1:]:
        words = line.split()
        assert words[0] == "hil", line
        if len(words) > 1 and not words[1].startswith("-"):
            assert words[1] in COMMANDS + GROUPS, line


def test_readme_activation_puts_hil_on_path() -> None:
    """Exactly as printed, from the repository, in a fresh shell without the venv on PATH."""
    venv_bin = Path(sys.executable).parent
    if venv_bin != REPO / ".venv" / "bin":
        pytest.skip("the tests do not run from the README's .venv")
    env = {"PATH": "/usr/bin:/bin", "HOME": str(Path.home())}
    proc = subprocess.run(["sh", "-c", ". .venv/bin/activate && command -v hil && hil faults --help"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == str(REPO / ".venv" / "bin" / "hil")
    assert re.search(r"Exit status: 0", proc.stdout)
