"""docs/fidelity.md's figures are what the bench flies today.

Lockstep flights are a function of the rig, the scenario and the seed, so flying one of the
doc's experiments again on its first seed must give the values the doc lists for that seed, to
the three significant digits it prints. The shortest experiment (the paper-literal weights,
16 s) and the 2 Hz attitude tracking (20 s) stand for the rest; a change to the plant, the device
models or the flight code that moves the flight moves them, and then `hil fidelity --seeds 5`
must be run again. tests/unit/campaign/test_fidelity_doc.py checks that the rest of the file
is the generator's output for those values.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hil.fleet.fidelity import ROWS
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]

DOC = Path(__file__).resolve().parents[2] / "docs" / "fidelity.md"


def _doc_values(seed: int) -> list[str]:
    m = re.search(rf"^\* seed {seed}: (.*)$", DOC.read_text(), flags=re.M)
    assert m, f"docs/fidelity.md has no values for seed {seed}"
    return m.group(1).split(", ")


def _doc_seeds() -> list[int]:
    m = re.search(r"seeds ([\d, ]+), lockstep", DOC.read_text())
    assert m, "docs/fidelity.md names no seeds"
    return [int(s) for s in m.group(1).split(", ")]


def _first_seed() -> int:
    return _doc_seeds()[0]


@pytest.mark.parametrize("scenario", ["paper-literal-weights", "attitude-2hz"])
async def test_doc_values_are_todays_flight(fly, scenario: str) -> None:
    seed = _first_seed()
    result = await fly(scenario, seed=seed)
    by_name = {c.name: c for c in result.criteria}
    doc = _doc_values(seed)
    checked = 0
    for i, row in enumerate(ROWS):
        if row.scenario != scenario:
            continue
        value = max((by_name[n].value for n in row.criteria), key=abs)
        assert f"{value:.3g}" == doc[i], (
            f"{row.figure} / {row.claim}: seed {seed} flies {value:.3g}, docs/fidelity.md says {doc[i]}; "
            "run `hil fidelity --seeds 5` again. " + explain(result))
        # the figure tells flights apart: another seed's flight gives another value
        others = {_doc_values(s)[i] for s in _doc_seeds() if s != seed}
        assert others - {doc[i]}, f"{row.figure}: every seed has {doc[i]}; the comparison would not see a change"
        checked += 1
    assert checked > 0
