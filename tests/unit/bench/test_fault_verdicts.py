"""fault-adc-garbage's verdicts on synthetic flights: the reaction is judged within windows
after the fault, and "recovered" needs the ADC to be read again (the bench's count of
conversions served) with a finite barometric altitude on truth."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from hil.analysis.criteria import evaluate
from hil.analysis.trace import Trace
from hil.config import SCENARIOS_DIR
from hil.config.scenario import load_scenario

TICK_NS = 2_500_000
TM_NS = 20_000_000


def _flight(conversions_per_tick: Callable[[float], int], failed_reads: Callable[[float], float],
            baro_m: Callable[[float, float], float], duration_s: float = 20.0) -> Trace:
    """A 2 m hover with the ADC's bench count, failed reads and baro altitude given by time."""
    rng = np.random.default_rng(1)
    tr = Trace()
    tr.define("truth", {"h_m": 1})
    tr.define("dev", {"adc_conversions": 1})
    served = 0
    for k in range(int(duration_s * 400)):
        t_s = k * TICK_NS / 1e9
        served += conversions_per_tick(t_s)
        tr.row("truth", k * TICK_NS, (2.0,))
        tr.row("dev", k * TICK_NS, (float(served),))
    for k in range(int(duration_s * 50)):
        t_s = k * TM_NS / 1e9
        tr.point("tm.adc_failed_reads", k * TM_NS, failed_reads(t_s))
        tr.point("tm.alt_baro_m", k * TM_NS, baro_m(t_s, 2.0 + rng.normal(0.0, 0.44)))
    return tr


def _in_fault(t_s: float) -> bool:
    return 10.0 <= t_s < 11.0


def _good_reads(t_s: float) -> int:
    return 0 if _in_fault(t_s) else 4


def _failed(t_s: float) -> float:
    """2 failed reads at boot, 3 more during the garbage."""
    return 2.0 + (0 if t_s < 10.2 else 1 if t_s < 10.5 else 3)


def _baro(t_s: float, good_m: float) -> float:
    """No altitude while the ADC answers garbage, then the readings again."""
    return math.nan if _in_fault(t_s) else good_m


FLIGHTS = {
    "recovered": (_good_reads, _failed, _baro),
    # stopped reading at the fault: no failed reads after it, the altitude held at its last value
    "stopped reading": (lambda t: 4 if t < 10.0 else 0, _failed, lambda t, m: 2.1 if t >= 10.0 else m),
    # stuck re-entering the bridge (counted as no_transfer, not as failed reads): nothing served
    "stuck in the bridge": (lambda t: 4 if t < 10.0 else 0, _failed, lambda t, m: math.nan if t >= 10.0 else m),
    # never noticed the garbage: the count is the 2 at boot throughout
    "never saw it": (_good_reads, lambda t: 2.0, _baro),
    # read again, but the baro altitude came back 1 m off (a reference lost in the resync)
    # took the garbage as a pressure: the baro altitude jumps 30 m for a moment in the fault
    "took a corrupted reading": (_good_reads, _failed,
                                 lambda t, m: m + 30.0 if 10.2 <= t < 10.3 else _baro(t, m)),
    "baro off after": (_good_reads, _failed, lambda t, m: math.nan if 10.0 <= t < 11.5 else (m + 1.0 if t >= 11.5 else m)),
}


def _adc_criteria():
    scenario = load_scenario(SCENARIOS_DIR / "fault-adc-garbage.toml")
    return [c for c in scenario.criteria if not c.signal.startswith("truth.")]


@pytest.mark.parametrize("name", sorted(FLIGHTS))
def test_fault_adc_garbage_passes_only_a_driver_that_recovered(name: str) -> None:
    results = evaluate(_adc_criteria(), _flight(*FLIGHTS[name]))
    failed = [r.name for r in results if not r.passed]
    if name == "recovered":
        assert not failed, results
    else:
        assert failed, (name, results)


def test_the_reaction_is_judged_within_the_window_not_since_boot() -> None:
    """Failed reads at boot do not pass "saw the garbage"; the increase within the window does."""
    saw = next(c for c in _adc_criteria() if c.metric == "increase" and c.min == 1.0)
    (never,) = evaluate([saw], _flight(*FLIGHTS["never saw it"]))
    (seen,) = evaluate([saw], _flight(*FLIGHTS["recovered"]))
    assert not never.passed and never.value == 0.0
    assert seen.passed and seen.value == 3.0


def test_a_corrupted_reading_taken_fails_only_the_baro_criterion() -> None:
    """A driver that reads again but fused one garbage pressure fails on the altitude, nothing else."""
    results = evaluate(_adc_criteria(), _flight(*FLIGHTS["took a corrupted reading"]))
    assert [r.name for r in results if not r.passed] == [
        "no corrupted reading taken: barometric altitude within 2 m of truth during the fault"]
