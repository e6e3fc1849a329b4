"""One recorded run: the summary and `hil timing` agree on compute; the report's PNGs."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from hil.analysis.report import MOTOR_STYLES, figures, make_report
from hil.analysis.timing import analyze_log

pytestmark = [pytest.mark.system]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory):
    import asyncio

    from hil.config.rig import load_rig
    from hil.flight.run import run_flight_async
    from hil.config.scenario import load_scenario

    out = tmp_path_factory.mktemp("logs")
    rig = load_rig(None)
    source = rig.scenario_path("hover")
    result = asyncio.run(run_flight_async(rig, load_scenario(source), scenario_source=source,
                                          duration_s=1.5, out_dir=out))
    assert result.log_path is not None, result.message
    return result


def test_summary_and_hil_timing_give_one_compute_p99(recorded) -> None:
    rep = analyze_log(recorded.log_path)
    assert rep.compute_us.n > 0
    for fig, st in (("p50", rep.compute_us.p50), ("p99", rep.compute_us.p99), ("max", rep.compute_us.max)):
        assert math.isclose(recorded.timing[f"fc_compute_{fig}_us"], st, rel_tol=1e-9), fig


def test_report_keeps_hil_timing_png_and_names_its_own(recorded, tmp_path: Path) -> None:
    from hil.analysis.timing import plot_latency

    log: Path = recorded.log_path
    timing_png = plot_latency(log, tmp_path / (log.name.removesuffix(".mcap") + "_timing.png"), budget_us=1000.0)
    assert timing_png is not None
    before = timing_png.read_bytes()
    paths = make_report(log, tmp_path)
    names = sorted(p.name.removeprefix(log.name.removesuffix(".mcap")) for p in paths)
    assert names == ["_altitude.png", "_attitude.png", "_motors.png", "_report-timing.png"]
    assert timing_png.read_bytes() == before


def test_motors_distinguishable_and_legends_off_the_data(recorded) -> None:
    figs = dict(figures(recorded.log_path))
    try:
        styles = [(line.get_color(), line.get_linestyle()) for line in figs["motors"].axes[0].get_lines()]
        assert len(styles) == 4 and len(set(styles)) == 4
        assert len({c for c, _ in MOTOR_STYLES}) == 4 and len({s for _, s in MOTOR_STYLES}) == 4
        for fig in figs.values():
            fig.canvas.draw()
            renderer = fig.canvas.get_renderer()
            for ax in fig.axes:
                legend = ax.get_legend()
                if legend is None:
                    continue
                box, axes_box = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
                assert box.x0 >= axes_box.x1, f"legend over the data in {ax.get_title() or ax.get_ylabel()}"
    finally:
        import matplotlib.pyplot as plt

        for fig in figs.values():
            plt.close(fig)
