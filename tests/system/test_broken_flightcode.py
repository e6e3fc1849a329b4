"""Deliberately broken copies of the flight code fail the scenario written to catch them
(tests/system/broken_flightcode.py), and the unbroken copy, flown the same way, passes it:
the failure comes from the edit, not from flying a copy."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.flight.tickloop import EndReason
from tests.system.broken_flightcode import ROOT, VARIANTS, Variant, apply, build_rig
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


def test_every_edit_finds_its_anchor_once(tmp_path: Path) -> None:
    import shutil

    for i, variant in enumerate(VARIANTS):
        tree = tmp_path / str(i)
        shutil.copytree(ROOT / "flightcode", tree / "flightcode")
        edited = apply(tree, variant)
        original = ROOT / edited.relative_to(tree)
        assert edited.read_text() != original.read_text()


@pytest.mark.parametrize("variant", VARIANTS, ids=[v.name for v in VARIANTS])
async def test_broken_flight_code_fails_its_scenario(fly, tmp_path: Path, variant: Variant) -> None:
    result = await fly(variant.scenario, rig=str(build_rig(tmp_path, variant)), keep_trace=False)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    failed = {c.name for c in result.criteria if not c.passed}
    assert failed & variant.criteria, explain(result)
    assert not result.passed


async def test_the_unbroken_copy_passes(fly, tmp_path: Path) -> None:
    """The copy without an edit, run through the same command, passes the ADC scenario."""
    result = await fly("fault-adc-garbage", rig=str(build_rig(tmp_path, None)), keep_trace=False)
    assert result.passed, explain(result)
