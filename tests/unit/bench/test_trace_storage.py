"""The trace's storage: 8 bytes a value (typed arrays, not tuples of floats), numpy views
without copies that stay valid while rows keep coming. A memory measurement with a generous
bound (tracemalloc), not a timed assertion."""

from __future__ import annotations


import numpy as np
import pytest

from hil.analysis.trace import Trace
from tests.unit.bench.traced import traced

WIDTHS = {"a": 1, "b": 3, "c": 4}  # 8 columns


def _rows(n: int) -> Trace:
    tr = Trace()
    tr.define("g", WIDTHS)
    for k in range(n):
        tr.row("g", k * 2_500_000, tuple(float(k + i) for i in range(8)))
    return tr


def test_a_row_costs_about_its_values() -> None:
    n = 50_000
    tr, size = traced(lambda: _rows(n))
    assert size < 1.5 * n * (8 * 8 + 8), size  # tuples of floats took ~4x this
    assert tr.signal("g.b", grid="g")[1].shape == (n, 3)


def test_views_stay_valid_while_rows_keep_coming() -> None:
    tr = _rows(10)
    t, b = tr.signal("g.b", grid="g")
    before = b.copy()
    tr.row("g", 10 * 2_500_000, tuple(float(i) for i in range(8)))  # storage is exported: copied first
    assert np.array_equal(b, before)
    t2, b2 = tr.signal("g.b", grid="g")
    assert b2.shape == (11, 3) and np.array_equal(b2[:10], before) and b2[10].tolist() == [1.0, 2.0, 3.0]
    assert t2[-1] == pytest.approx(0.025)


def test_a_row_of_the_wrong_width_is_refused() -> None:
    tr = _rows(1)
    with pytest.raises(ValueError):
        tr.row("g", 0, (1.0, 2.0))


def test_points_are_held_on_the_tick_grid() -> None:
    tr = _rows(4)
    tr.point("tm.x", 2_500_000, 7.0)
    _, held = tr.signal("tm.x", grid="g")
    assert np.isnan(held[0]) and held[1:].tolist() == [7.0, 7.0, 7.0]
    tr.point("tm.x", 5_000_000, 8.0)  # appending after a read
    assert tr.signal("tm.x", grid="g")[1][1:].tolist() == [7.0, 8.0, 8.0]
