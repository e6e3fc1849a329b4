"""``ExactSum`` (hil/analysis/online_stats.py): the step criteria's levels, summed block by block in
the stream and at once in the batch, must be the same float to the bit."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from hil.analysis.online_stats import ExactSum

finite = st.floats(-1e12, 1e12, allow_nan=False, allow_infinity=False)
#: every finite double: subnormals, the largest, both zeros (sums may overflow: see below)
any_finite = st.floats(allow_nan=False, allow_infinity=False)


def _summed(blocks: list[list[float]]) -> ExactSum:
    total = ExactSum()
    for block in blocks:
        total.add(np.asarray(block, dtype=float))
    return total


@given(st.lists(st.lists(finite, max_size=20), max_size=20))
def test_any_split_gives_fsum_of_the_whole(blocks: list[list[float]]) -> None:
    flat = [x for block in blocks for x in block]
    total = _summed(blocks)
    assert total.count == len(flat)
    assert total.total() == math.fsum(flat)
    assert (math.isnan(total.mean()) if not flat else total.mean() == math.fsum(flat) / len(flat))


@given(st.lists(st.lists(any_finite, max_size=30), max_size=10))
def test_any_finite_doubles_give_the_exact_sum_rounded_once(blocks: list[list[float]]) -> None:
    # the oracle is the exact rational sum rounded once (fsum is that too, but it raises on an
    # intermediate overflow even where the rounded result is finite)
    exact = sum(map(Fraction, (x for block in blocks for x in block)), Fraction(0))
    try:
        expected = float(exact)
    except OverflowError:  # rounds beyond the largest float: an infinity of its sign
        expected = math.inf if exact > 0 else -math.inf
    assert _summed(blocks).total() == expected


@given(st.floats(1.0, 2.0, exclude_max=True), st.integers(1, 3000), st.integers(-1074, 971))
def test_long_blocks_of_one_exponent_are_exact(x: float, n: int, e: int) -> None:
    # thousands of significands of one exponent: their int64 sums must not overflow
    v = math.ldexp(x, e)
    assert _summed([[v] * n]).total() == math.fsum([v] * n)


def test_subnormals_and_the_largest_double() -> None:
    tiny = 5e-324
    assert _summed([[tiny] * 3, [-tiny]]).total() == 2 * tiny
    big = 1.7976931348623157e308
    assert _summed([[big, -big], [tiny]]).total() == tiny
    assert _summed([[big], [big], [-big]]).total() == big  # past the range on the way, not at the end


@given(st.lists(finite, min_size=1, max_size=60), st.randoms(use_true_random=False))
def test_the_order_does_not_matter(values: list[float], rnd) -> None:  # type: ignore[no-untyped-def]
    shuffled = list(values)
    rnd.shuffle(shuffled)
    assert _summed([values]).total() == _summed([[x] for x in shuffled]).total()


def test_a_sum_numpy_rounds_differently_is_exact() -> None:
    # 0.1 ten times: naive and pairwise sums are 0.9999999999999999, the exact sum rounds to 1.0
    assert _summed([[0.1] * 3, [0.1] * 7]).total() == 1.0
    assert _summed([[1e16, 1.0], [-1e16]]).total() == 1.0  # the 1.0 survives the cancellation


def test_non_finite_values_follow_numpy() -> None:
    assert math.isnan(_summed([[1.0, math.nan]]).total())
    assert math.isnan(_summed([[math.inf], [-math.inf]]).total())
    assert _summed([[1.0], [math.inf]]).total() == math.inf
    assert _summed([[-math.inf, 2.0]]).mean() == -math.inf
    assert _summed([[1e308], [1e308]]).total() == math.inf  # beyond the largest float
    assert math.isnan(ExactSum().mean())
