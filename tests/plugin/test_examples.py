"""The example file users copy (examples/test_my_flight_code.py) passes as shipped."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest_plugins = ["pytester"]
pytestmark = [pytest.mark.system, pytest.mark.pty]

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "test_my_flight_code.py"


def test_example_file_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_my_flight_code=EXAMPLE.read_text())
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-v")
    result.assert_outcomes(passed=3)
    result.stdout.no_fnmatch_line("*hil-bench: MCAP logs kept*")
