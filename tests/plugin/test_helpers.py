"""The plugin's pure parts: scenario building, file names, option parsing, predicate labels."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.config import ConfigError
from hil.pytest_plugin import keep_dir_of
from hil.testing.factory import _safe
from hil.testing.scenario import INLINE_DURATION_S, build_scenario
from hil.testing.simtime import _label_of
from hil.config.rig import load_rig

pytest_plugins = ["pytester"]

ARM = {"t_s": 0.5, "action": "arm"}


@pytest.fixture(scope="module")
def rig():
    return load_rig(None)


def test_named_scenario_keeps_its_file(rig) -> None:
    scen, source = build_scenario(rig, "hover")
    assert source is not None and source.name == "hover.toml"
    assert scen.name == "hover" and scen.scenario.duration_s == 30.0
    assert len(scen.criteria) == 14


def test_inline_scenario_gets_a_header(rig) -> None:
    scen, source = build_scenario(rig, None, sticks=[ARM], name="test_x")
    assert source is None
    assert scen.name == "test_x" and scen.scenario.duration_s == INLINE_DURATION_S
    assert [s.action for s in scen.sticks] == ["arm"]
    scen, _ = build_scenario(rig, {"sticks": [ARM]}, duration_s=4.0, name="t")
    assert scen.scenario.duration_s == 4.0
    scen, _ = build_scenario(rig, {"scenario": {"name": "mine", "duration_s": 2.0, "seed": 7}}, name="t")
    assert (scen.name, scen.scenario.duration_s, scen.scenario.seed) == ("mine", 2.0, 7)


def test_sticks_replace_and_flight_merges(rig) -> None:
    scen, source = build_scenario(rig, "hover", sticks=[ARM], flight={"failsafe": {"rc_loss_s": 0.3}})
    assert source is not None  # still attached as the hover file; the sticks are the test's
    assert [s.action for s in scen.sticks] == ["arm"]
    assert scen.flight == {"failsafe": {"rc_loss_s": 0.3}}
    assert scen.wind is not None and scen.wind.dryden  # the file's turbulence stays
    scen2, _ = build_scenario(rig, scen, flight={"failsafe": {"descend_mps": 1.0}})
    assert scen2.flight == {"failsafe": {"rc_loss_s": 0.3, "descend_mps": 1.0}}


def test_bad_inline_scenarios_are_refused(rig) -> None:
    with pytest.raises(ConfigError, match="must not decrease"):
        build_scenario(rig, None, sticks=[{"t_s": 2.0, "action": "arm"}, {"t_s": 1.0, "action": "disarm"}])
    with pytest.raises(ConfigError, match="wind_speed"):
        build_scenario(rig, {"wind_speed": 3})
    with pytest.raises(ConfigError, match="no such scenario"):
        build_scenario(rig, "no-such-scenario")


async def test_bad_scenario_faults_are_refused_before_anything_starts(hil_bench) -> None:
    with pytest.raises(ConfigError, match=r"\[\[faults\]\] #0 \(imu.silence\) t_s: missing"):
        await hil_bench.start(scenario={"faults": [{"kind": "imu.silence"}]}, duration_s=1.0)
    with pytest.raises(ConfigError, match="unknown fault kind"):
        await hil_bench.start(scenario={"faults": [{"kind": "imu.slience", "t_s": 0.1}]}, duration_s=1.0)
    assert hil_bench.benches == []


def test_safe_names() -> None:
    assert _safe("tests/plugin/test_a.py::test_x[seed-1 / 2]") == "tests-plugin-test_a.py--test_x_seed-1_-_2"
    assert _safe("::test_y") == "test_y"
    assert len(_safe("x" * 400)) == 150


def test_predicate_labels() -> None:
    def high(bench: object) -> bool:
        return True

    assert _label_of(high) == "high"
    assert _label_of(lambda b: b.truth.h_m > 1.5) == "lambda b: b.truth.h_m > 1.5"
    assert _label_of(lambda b: max(b.x, (1, 2)) <= [3][0]) == "lambda b: max(b.x, (1, 2)) <= [3][0]"
    labels = [_label_of(f) for f in (lambda b: b.flight_mode == "ARMED",)]
    assert labels == ['lambda b: b.flight_mode == "ARMED"']


def test_keep_dir_option_ini_and_default(pytester: pytest.Pytester, tmp_path: Path) -> None:
    config = pytester.parseconfig("--hil-keep-logs", "kept")
    assert keep_dir_of(config, tmp_path) == Path(config.invocation_params.dir, "kept")
    assert config.getoption("hil_keep_all") is False
    config = pytester.parseconfig()
    assert keep_dir_of(config, tmp_path) == tmp_path / "hil-logs"
    pytester.makeini("[pytest]\nhil_keep_logs = /var/tmp/hil\n")
    config = pytester.parseconfig("--hil-keep-all")
    assert keep_dir_of(config, tmp_path) == Path("/var/tmp/hil")
    assert config.getoption("hil_keep_all") is True


def test_users_of_the_fixture_get_the_marker(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_m="""
        async def test_bench(hil_bench):
            pass

        def test_plain():
            pass
    """)
    pytester.makeini("[pytest]\nasyncio_default_fixture_loop_scope = function\n")
    result = pytester.runpytest("--collect-only", "-q", "-m", "not hil_bench", "-p", "no:cacheprovider",
                                "--strict-markers")
    result.stdout.fnmatch_lines(["test_m.py::test_plain", "*1/2 tests collected (1 deselected)*"])
