"""A board run's own criteria (hil/flight/board_timing.py) pass on good figures and fail on each
bad one; the compute budget on a board is judged in target cycles, never "not judged"."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight.board_timing import board_criteria
from hil.flight.scenario_runner import ScenarioRunner

ROOT = Path(__file__).resolve().parents[3]
GOOD = {"board_cclk_hz": 60e6, "board_uart0_rx_overruns": 0.0, "board_uart1_rx_overruns": 0.0,
        "board_esc_pulses_late": 0.0, "board_esc_pulses_missed": 0.0,
        "board_stack_svc_used_B": 5148.0, "board_stack_svc_size_B": 5632.0,
        "board_stack_irq_used_B": 56.0, "board_stack_irq_size_B": 1024.0}


def by_name(timing: dict[str, float]) -> dict[str, bool]:
    return {c.name: c.passed for c in board_criteria(timing)}


def test_good_figures_pass_every_board_criterion() -> None:
    assert by_name(GOOD) == {"board: stacks within their regions": True, "board: no UART RX overrun": True,
                             "board: ESC pulses on time": True}
    stacks = next(c for c in board_criteria(GOOD) if c.name.startswith("board: stacks"))
    assert "svc 5148 of 5632 B" in stacks.detail


@pytest.mark.parametrize(("key", "value", "failed"), [
    ("board_stack_irq_used_B", 1024.0, "board: stacks within their regions"),  # written to its last word
    ("board_uart0_rx_overruns", 3.0, "board: no UART RX overrun"),
    ("board_uart1_rx_overruns", 1.0, "board: no UART RX overrun"),
    ("board_esc_pulses_late", 1.0, "board: ESC pulses on time"),
    ("board_esc_pulses_missed", 2.0, "board: ESC pulses on time"),
])
def test_each_criterion_fails_on_its_figure(key: str, value: float, failed: str) -> None:
    result = by_name(GOOD | {key: value})
    assert not result[failed]
    assert all(passed for name, passed in result.items() if name != failed)


def budget(rig_name: str, value_us: float) -> tuple[bool, bool, str]:
    rig = load_rig(ROOT / "rigs" / rig_name)
    runner = ScenarioRunner(load_scenario(rig.scenario_path("hover")), rig)
    c = next(c for c in runner.timing_criteria({"fc_compute_p99_us": value_us, "board_cclk_hz": 60e6}, None)
             if c.signal == "timing.fc_compute_p99_us")
    return c.passed, c.judged, c.detail


def test_the_compute_budget_is_judged_in_target_cycles_on_the_board() -> None:
    assert budget("paper-quad-lpc2148.toml", 1845.0) == (
        True, True, "judged on the emulated LPC2148 at 60 MHz (target cycles); margin 655 us (26% of the budget)")
    passed, judged, detail = budget("paper-quad-lpc2148.toml", 3045.0)
    assert (passed, judged) == (False, True) and detail.endswith("over by 545 us (22% of the budget)")
    assert budget("paper-quad-lpc2148.toml", math.nan)[:2] == (False, True)
    # a process rig without a calibration: reported, not judged
    assert budget("paper-quad-c.toml", 3045.0)[:2] == (True, False)
