"""The [falsify] table of a scenario (hil/fleet/falsify/space.py): keys into the file's own
tables, ranges checked at both ends, each point written as a scenario that loads, and every
bad input named by file, key and reason."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.config import ConfigError
from hil.config.scenario import load_scenario
from hil.fleet.falsify.space import get_value, load_space

ROOT = Path(__file__).resolve().parents[3]
#: the shipped scenario without its own [falsify] table (each test writes one)
BASE = (ROOT / "rigs" / "scenarios" / "fault-payload.toml").read_text().split("\n# What `hil falsify` may vary")[0]


def scenario(tmp_path: Path, vary: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(BASE + "\n" + vary)
    return path


MASS_AND_SEED = '''
[[falsify.vary]]
key = "faults.0.extra_mass_kg"
range = [0.05, 0.6]

[[falsify.vary]]
key = "scenario.seed"
range = [1, 1000]
integer = true
'''


@settings(max_examples=50, deadline=None)
@given(mass=st.floats(-1.0, 2.0), seed=st.floats(-10, 2000))
def test_every_point_is_a_scenario_with_those_values_clamped_to_the_ranges(tmp_path_factory, mass: float,
                                                                          seed: float) -> None:
    tmp = tmp_path_factory.mktemp("p")
    space = load_space(scenario(tmp, MASS_AND_SEED))
    values = space.values([mass, seed])
    assert 0.05 <= values["faults.0.extra_mass_kg"] <= 0.6
    assert isinstance(values["scenario.seed"], int) and 1 <= values["scenario.seed"] <= 1000
    written = load_scenario(space.write(values, tmp / "point.toml", "a point"))
    assert written.falsify is None  # a point is one flight, not a search
    assert written.scenario.seed == values["scenario.seed"]
    assert written.faults[0]["extra_mass_kg"] == values["faults.0.extra_mass_kg"]
    assert written.criteria == space.scenario.criteria


@pytest.mark.parametrize(("vary", "says"), [
    ("", "[falsify]: missing"),
    ('[[falsify.vary]]\nkey = "faults.0.mass_kg"\nrange = [0.1, 0.2]\n', "vary.0.key: 'faults.0.mass_kg' is not set"),
    ('[[falsify.vary]]\nkey = "faults.3.t_s"\nrange = [9, 11]\n', "vary.0.key: 'faults.3.t_s' is not set"),
    ('[[falsify.vary]]\nkey = "faults.0.kind"\nrange = [0, 1]\n', "is 'plant.payload', not a number"),
    ('[[falsify.vary]]\nkey = "criteria.0.min"\nrange = [0, 1]\n', "varies the flight, not its criteria"),
    ('[[falsify.vary]]\nkey = "faults.0.t_s"\nrange = [12, 11]\n', "lo < hi"),
    ('[[falsify.vary]]\nkey = "faults.0.extra_mass_kg"\nrange = [0.1, 0.2]\ninteger = true\n',
     "integer = true needs a whole number"),
    ('[[falsify.vary]]\nkey = "scenario.duration_s"\nrange = [-5, 10]\n',
     "vary.0.range: scenario.duration_s = -5.0 makes the scenario invalid"),
])
def test_a_bad_falsify_table_is_named_with_its_key_and_reason(tmp_path: Path, vary: str, says: str) -> None:
    path = scenario(tmp_path, vary)
    with pytest.raises(ConfigError) as exc:
        load_space(path)
    assert str(path) in str(exc.value) and says in str(exc.value), str(exc.value)


def test_a_key_reaches_into_lists_of_lists() -> None:
    data = {"wind": {"mean_N_mps": [2.0, 1.0, 0.0]}, "sticks": [{"t_s": 0.5}, {"pulse_us": 1200}]}
    assert get_value(data, "wind.mean_N_mps.1") == 1.0
    assert get_value(data, "sticks.1.pulse_us") == 1200
