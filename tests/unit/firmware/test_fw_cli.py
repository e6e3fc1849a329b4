"""`hil firmware build`: the host build through the firmware's Makefile, and its errors."""

from __future__ import annotations

from typer.testing import CliRunner

from hil.cli import app
from tests.unit.firmware.fwbuild import HOST_BIN


def test_builds_the_host_program() -> None:
    result = CliRunner().invoke(app, ["firmware", "build"])
    assert result.exit_code == 0, result.output
    assert "built the firmware's host target" in result.output
    assert HOST_BIN.is_file()


def test_an_unknown_target_is_bad_input() -> None:
    result = CliRunner().invoke(app, ["firmware", "build", "--target", "avr"])
    assert result.exit_code == 2
    assert "unknown target 'avr'" in result.output
