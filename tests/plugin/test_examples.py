"""The example file users copy (examples/test_my_flight_code.py) passes as shipped; with
--hil-keep-all the passing tests' MCAPs are kept too."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.record import read_metadata

pytest_plugins = ["pytester"]
pytestmark = [pytest.mark.system, pytest.mark.pty]

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "test_my_flight_code.py"
TESTS = ("test_take_off_and_hover", "test_rc_loss_descends_and_disarms_on_the_ground",
         "test_imu_silence_stops_the_motors", "test_a_short_imu_stall_is_flown_through")


def test_example_file_passes(pytester: pytest.Pytester, tmp_path: Path) -> None:
    pytester.makepyfile(test_my_flight_code=EXAMPLE.read_text())
    keep = tmp_path / "kept"
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-v", "--hil-keep-logs", str(keep),
                                           "--hil-keep-all")
    result.assert_outcomes(passed=len(TESTS))
    assert sorted(p.name for p in keep.iterdir()) == sorted(f"test_my_flight_code.py--{t}.mcap" for t in TESTS)
    for name in TESTS:
        meta = read_metadata(keep / f"test_my_flight_code.py--{name}.mcap")
        assert meta["run"]["scenario"] == name and meta["run"]["rig"] == "paper-quad"
    result.stdout.fnmatch_lines(["*- hil-bench: MCAP logs kept -*", f"test_my_flight_code.py::{TESTS[0]}: {keep}/*"])
