"""Steal time (hil/host/steal.py): read from the kernel's per-CPU accounting, measured over a
stretch, and turned into a realtime run's note only when misses came with it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from hil.host.steal import PROC_STAT, StealMeter, read_steal_ms, realtime_note

HZ = os.sysconf("SC_CLK_TCK")


def _stat(path: Path, steal_ticks: int | None) -> Path:
    values = "4705 150 1120 16250 520 0 21"
    if steal_ticks is not None:
        values += f" {steal_ticks} 0 0"
    path.write_text(f"cpu  {values}\ncpu0 {values}\nintr 12345\nctxt 678\n")
    return path


def test_reads_the_steal_column_of_the_all_cpus_line(tmp_path: Path) -> None:
    assert read_steal_ms(_stat(tmp_path / "stat", 42)) == pytest.approx(42 * 1000 / HZ)
    assert read_steal_ms(_stat(tmp_path / "stat", 0)) == 0.0


@pytest.mark.parametrize("text", ["cpu  1 2 3 4 5 6 7\n", "intr 1 2 3 4 5 6 7 8 9\n", "cpu  1 2 3 4 5 6 7 x 0 0\n", ""])
def test_a_kernel_without_the_count_gives_none(tmp_path: Path, text: str) -> None:
    path = tmp_path / "stat"
    path.write_text(text)
    assert read_steal_ms(path) is None


def test_no_such_file_gives_none(tmp_path: Path) -> None:
    assert read_steal_ms(tmp_path / "missing") is None


def test_the_meter_gives_the_steal_time_between_start_and_stop(tmp_path: Path) -> None:
    path = _stat(tmp_path / "stat", 100)
    meter = StealMeter(path)
    assert meter.stop() is None  # never started
    meter.start()
    _stat(path, 103)
    assert meter.stop() == pytest.approx(3 * 1000 / HZ)


def test_the_meter_gives_none_where_the_count_is_missing_at_either_end(tmp_path: Path) -> None:
    missing = StealMeter(tmp_path / "missing")
    missing.start()
    assert missing.stop() is None
    path = _stat(tmp_path / "stat", 100)
    gone = StealMeter(path)
    gone.start()
    path.unlink()
    assert gone.stop() is None


def test_this_host_counts_steal_time() -> None:
    if not PROC_STAT.exists():
        pytest.skip("no /proc/stat")
    before = read_steal_ms()
    assert before is not None and before >= 0.0  # every Linux since 2.6.11 has the column
    meter = StealMeter()
    meter.start()
    steal_ms = meter.stop()
    assert steal_ms is not None and steal_ms >= 0.0


@pytest.mark.parametrize(("steal_ms", "late", "no_command"), [(0.0, 5, 3), (20.0, 0, 0)])
def test_no_note_without_both_steal_time_and_misses(steal_ms: float, late: int, no_command: int) -> None:
    assert realtime_note(steal_ms, late, no_command) is None


def test_the_note_gives_the_steal_time_and_the_misses() -> None:
    text = realtime_note(30.0, 7, 4)
    assert text is not None
    assert "30 ms" in text and "7 late ticks" in text and "4 samples without a command" in text
    assert "steal time" in text and "docs/time.md" in text
