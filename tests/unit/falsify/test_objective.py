"""The number hil falsify drives below zero (hil/fleet/falsify/objective.py): below zero
exactly when the flight failed; margins compared in each criterion's own scale; a share that
must be all or nothing counts only when it fails."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from hil.config.scenario import Criterion
from hil.fleet.falsify.objective import FAILED, focused, robustness, scale

HEIGHT = Criterion(name="held", signal="truth.h_m", metric="mean", min=1.8, max=2.2)
ROLL = Criterion(name="roll", signal="truth.roll_deg", metric="max_abs", max=3.0)
MODE = Criterion(name="disarmed", signal="tm.mode", metric="fraction_in", lo=1, hi=1, min=1.0)
CRITERIA = {c.name: c for c in (HEIGHT, ROLL, MODE)}


def result(*rows: tuple[str, float | None, bool], end: str = "completed") -> dict[str, object]:
    return {"end_reason": end, "criteria": [{"name": n, "margin": m, "passed": p} for n, m, p in rows]}


@given(h=st.floats(-0.5, 0.5), r=st.floats(-3.0, 3.0), mode_ok=st.booleans())
def test_below_zero_exactly_when_a_criterion_failed(h: float, r: float, mode_ok: bool) -> None:
    res = result(("held", h, h >= 0), ("roll", r, r >= 0), ("disarmed", 0.0 if mode_ok else -1.0, mode_ok))
    value, name = robustness(res, CRITERIA)
    failed = h < 0 or r < 0 or not mode_ok
    assert (value < 0) == failed, (value, name)
    if not failed:  # the mode's 0 does not pin it, nor does a margin of exactly 0 (at a limit by design)
        expected = min(h / 0.2 if h else math.inf, r / 3.0 if r else math.inf, -FAILED)
        assert math.isclose(value, expected), value


def test_scales_and_failures_without_a_margin() -> None:
    assert math.isclose(scale(HEIGHT), 0.2) and scale(ROLL) == 3.0 and scale(MODE) == 1.0
    value, name = robustness(result(("held", 0.1, True), ("roll", 0.3, True)), CRITERIA)
    assert name == "roll" and math.isclose(value, 0.1)  # 0.3 deg of 3 is nearer than 0.1 m of 0.2
    assert robustness(result(("held", None, False)), CRITERIA) == (FAILED, "held")  # an empty window
    crashed = robustness(result(end="flight exited"), CRITERIA)
    assert crashed[0] == FAILED and "flight exited" in crashed[1]
    assert robustness(result(("held", -0.0, False)), CRITERIA)[0] < 0  # failed at exactly the bound


def test_a_focus_counts_only_the_criteria_it_names() -> None:
    res = result(("held", 0.02, True), ("roll", -0.5, False), ("disarmed", 0.0, True))
    assert robustness(res, CRITERIA)[0] < 0  # unaimed: the roll's failure is the flight's
    value, name = robustness(res, CRITERIA, focus=("HELD",))  # aimed, case-insensitive
    assert name == "held" and math.isclose(value, 0.1)
    assert robustness(res, CRITERIA, focus=("held", "roll"))[1] == "roll"
    assert focused("altitude held", ("held",)) and not focused("roll", ("held",)) and focused("roll", ())
    assert robustness(result(end="flight exited"), CRITERIA, focus=("held",))[0] == FAILED  # a crash fails any aim
