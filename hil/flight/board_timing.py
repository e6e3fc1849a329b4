"""A board run's timing verdicts, in target cycles (docs/board.md, "Timing verdicts").

The figures (``timing`` keys, recorded in the verdict, printed by the summary):

| key | what |
|---|---|
| ``board_cclk_hz`` | the core's clock as the firmware set it (60 MHz) |
| ``board_loop_busy_{p50,p99,max}_cycles`` | busy cycles of the loop iterations that answered a sample (``fc_compute_*_us`` are the same in us) |
| ``board_cpu_load_pct``, ``board_cpu_load_max_pct`` | busy cycles over all cycles of the flight; the busiest tick's share |
| ``board_irq_latency_{p50,p99,max}_cycles``, ``board_irqs`` | VIC request to exception entry |
| ``board_uart{0,1}_rx_overruns`` | characters lost to a full RX FIFO (the UART model's LSR.OE) |
| ``board_esc_pulses_late``, ``board_esc_pulses_missed`` | match-output ESC pulses a period late, or not made |
| ``board_samples_processed``, ``board_samples_dropped`` | IMU samples the loop processed; emitted ones it never did |
| ``board_stack_<mode>_used_B``, ``_size_B`` | each mode's stack high-water mark and region (the startup's paint) |
| ``board_instructions`` | instructions the core executed in the flight |

The board's criteria (always judged on a board run, each able to fail): the stacks stay
inside their regions, no UART character is lost to an overrun, no ESC pulse is late or
missed. Samples dropped are a figure, not a criterion: a wire fault that corrupts the IMU's
bytes drops samples by design.
"""

from __future__ import annotations

from hil.analysis.criteria import CriterionResult
from hil.analysis.timing_stream import StreamingStats
from hil.board.stacks import stack_use
from hil.flight.board_loop import BoardTickLoop


def _percentiles(prefix: str, stats: StreamingStats) -> dict[str, float]:
    if not stats:
        return {}
    return {f"{prefix}_p50_cycles": stats.percentile(50), f"{prefix}_p99_cycles": stats.percentile(99),
            f"{prefix}_max_cycles": stats.max}


def board_figures(loop: BoardTickLoop) -> dict[str, float]:
    """The figures of the table above, at the end of the run."""
    wiring = loop.wiring
    core, bus, escs = wiring.core, wiring.bus, wiring.escs
    cclk = bus.cclk_hz
    out: dict[str, float] = {"board_cclk_hz": float(cclk)}
    busy = StreamingStats(ns * cclk / 1e9 for ns in loop.stats.fc_cpu_ns)
    out |= _percentiles("board_loop_busy", busy)
    if loop.run_cycles:
        out["board_cpu_load_pct"] = 100.0 * loop.busy_cycles / loop.run_cycles
        out["board_cpu_load_max_pct"] = loop.load_pct.max
    out |= _percentiles("board_irq_latency", loop.irq_latency)
    out["board_irqs"] = float(loop.irq_latency.n)
    out["board_uart0_rx_overruns"] = float(bus.uart0.counters["rx_overruns"])
    out["board_uart1_rx_overruns"] = float(bus.uart1.counters["rx_overruns"])
    out["board_esc_pulses_late"] = float(escs.late)
    out["board_esc_pulses_missed"] = float(escs.missed)
    out["board_samples_processed"] = float(loop.samples_processed)
    out["board_samples_dropped"] = float(max(loop.stats.samples - loop.samples_processed, 0))
    for use in stack_use(wiring.image, core.read_memory):
        out[f"board_stack_{use.mode}_used_B"] = float(use.used_B)
        out[f"board_stack_{use.mode}_size_B"] = float(use.size_B)
    out["board_instructions"] = float(core.counter.state.instructions)
    return out


def board_criteria(timing: dict[str, float]) -> list[CriterionResult]:
    """The board's own criteria on its figures (see the module docstring)."""
    out: list[CriterionResult] = []
    modes = sorted(k.removeprefix("board_stack_").removesuffix("_used_B") for k in timing
                   if k.startswith("board_stack_") and k.endswith("_used_B"))
    if modes:
        over = [m for m in modes if timing[f"board_stack_{m}_used_B"] >= timing[f"board_stack_{m}_size_B"]]
        worst = max(modes, key=lambda m: timing[f"board_stack_{m}_used_B"] / max(timing[f"board_stack_{m}_size_B"], 1))
        used, size = timing[f"board_stack_{worst}_used_B"], timing[f"board_stack_{worst}_size_B"]
        detail = (f"written to the end of its region: {', '.join(over)}" if over
                  else f"fullest: {worst} {used:.0f} of {size:.0f} B")
        out.append(CriterionResult("board: stacks within their regions", "timing.board_stack_*_used_B",
                                   "high-water mark", used, f"< region ({size:.0f} B)", not over, detail,
                                   margin=min(timing[f"board_stack_{m}_size_B"] - timing[f"board_stack_{m}_used_B"]
                                              for m in modes) - 1.0))
    overruns = timing.get("board_uart0_rx_overruns", 0.0) + timing.get("board_uart1_rx_overruns", 0.0)
    out.append(CriterionResult("board: no UART RX overrun", "timing.board_uart*_rx_overruns", "count", overruns,
                               "== 0", overruns == 0,
                               "" if overruns == 0 else "characters lost to a full RX FIFO: a handler was late",
                               margin=-overruns))
    late = timing.get("board_esc_pulses_late", 0.0) + timing.get("board_esc_pulses_missed", 0.0)
    out.append(CriterionResult("board: ESC pulses on time", "timing.board_esc_pulses_*", "count", late, "== 0",
                               late == 0, "" if late == 0 else
                               f"{timing.get('board_esc_pulses_late', 0):.0f} late, "
                               f"{timing.get('board_esc_pulses_missed', 0):.0f} missed", margin=-late))
    return out
