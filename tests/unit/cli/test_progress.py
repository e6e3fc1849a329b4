"""Plain progress lines for a stdout that is not a terminal."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hil.flight.progress import PlainProgress


def _drive(calls: list[tuple[float, str]], every_sim_s: float = 10.0) -> list[str]:
    lines: list[str] = []
    p = PlainProgress("rig/scen", lines.append, lambda: 2.0, every_sim_s=every_sim_s)
    for sim_s, phase in calls:
        p(sim_s, 110.0, phase)
    return lines


def test_one_line_per_phase_and_per_interval() -> None:
    calls = [(k * 0.1, "arm" if k < 30 else "take off" if k < 80 else "hover") for k in range(0, 260)]
    lines = _drive(calls)
    assert [line.split("phase: ")[1] for line in lines] == ["arm", "take off", "hover", "hover", "hover"]
    assert lines[0].startswith("rig/scen: sim    0.00/110.0 s (  0%)")
    assert "sim   10.00/110.0 s" in lines[3] and "sim   20.00/110.0 s" in lines[4]
    assert "RTF 5.0x" in lines[3]  # 10 sim s in 2 wall s


def test_rejects_a_non_positive_interval() -> None:
    with pytest.raises(ValueError, match="every_sim_s"):
        PlainProgress("x", print, lambda: 1.0, every_sim_s=0)


@given(st.lists(st.floats(min_value=0, max_value=1000, allow_nan=False), max_size=200))
def test_lines_bounded_by_sim_time_covered(times: list[float]) -> None:
    lines = _drive([(t, "hover") for t in sorted(times)])
    if times:
        assert 1 <= len(lines) <= int(max(times) // 10.0) + 1
    else:
        assert lines == []
