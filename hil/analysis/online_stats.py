"""Running aggregates of a signal, fed block by block, that give what numpy gives on the whole
array: the memory of the streaming criteria (hil/analysis/criteria_stream.py).

* :class:`Moments`: count, sum, sum of squares, min, max, max |x|, mean and M2 (Chan's
  pairwise update of Welford's), the first and last finite rows and the sum of squared row-to-row
  changes, rows at or beyond saturation limits. O(1) memory (one row).
* :class:`SineFit`: least-squares fit of ``s sin(wt) + c cos(wt) + offset`` kept as the 4x4
  triangular factor of the design matrix augmented with the data (QR updated per block):
  O(1) memory, and as well conditioned as ``numpy.linalg.lstsq`` on the whole window.
* :class:`ExactSum`: a sum rounded once at the end, whatever the blocks: the step criteria's
  levels, which the batch computes with it too, so that a band test on them cannot land on
  different sides of its bound in the two (a rounding of the last bit did).

A block is ``values`` of shape (m,) (one column) or (m, columns); rows with a non-finite value
are left out, as the batch criteria leave them out (hil/analysis/criteria.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: ``numpy.linalg.qr`` untyped: with ``mode="r"`` it returns the factor alone, while its
#: stubs promise a ``QRResult`` tuple, which compiled code (mypyc) would check at run time
_qr: Any = np.linalg.qr


def finite_rows(values: np.ndarray) -> np.ndarray:
    """The rows of ``values`` whose every column is finite."""
    if values.ndim == 1:
        return values[np.isfinite(values)]
    return values[np.all(np.isfinite(values), axis=1)]


#: every finite double is an integer multiple of 2**-1074; scaled by 2**SCALE_BITS, its
#: 53-bit significand times 2**(exponent - 53) is an integer shifted left by >= 0 bits
SCALE_BITS = 1074 + 53
#: significands summed in int64 per exponent at most this many at a time (2**9 * 2**53 < 2**63)
_BLOCK = 512


def scaled_sum(values: np.ndarray) -> int:
    """The exact sum of finite float64 ``values`` (shape (m,)) times ``2**SCALE_BITS``, an
    integer. Vectorized: the significands of equal exponents are summed in int64, and only one
    Python integer shift and add is made per distinct exponent."""
    total = 0
    for start in range(0, values.size, _BLOCK):
        mant, exp = np.frexp(values[start : start + _BLOCK])  # x = mant * 2**exp, 0.5 <= |mant| < 1
        sig = np.ldexp(mant, 53).astype(np.int64)  # exact: a double has 53 significant bits
        shift = exp.astype(np.int64) + (SCALE_BITS - 53)
        order = np.argsort(shift, kind="stable")
        shift, sig = shift[order], sig[order]
        first = np.flatnonzero(np.concatenate(([True], shift[1:] != shift[:-1])))
        for part, bits in zip(np.add.reduceat(sig, first).tolist(), shift[first].tolist()):
            total += part << bits
    return total


class ExactSum:
    """Sum and mean of floats fed in any number of blocks, equal to ``math.fsum`` of them all
    at once: the exact sum of the finite values (an integer, scaled by ``2**SCALE_BITS``),
    rounded once when read. NaN, or +inf with -inf, gives NaN; an infinity of one sign gives it.
    Why: a level summed block by block and the same level from ``numpy.mean`` of the whole
    array can differ in the last bit (docs/architecture.md, the criteria stream). Cost: about
    0.1 us a value (a ``Fraction`` per value, the first version, took 6 us)."""

    __slots__ = ("_scaled", "count", "_special")

    def __init__(self) -> None:
        self._scaled = 0
        self.count = 0
        #: the sum of the non-finite values, which float addition gets right: 0.0 while there
        #: are none, then an infinity of one sign, or NaN
        self._special = 0.0

    def add(self, values: np.ndarray) -> None:
        """Add every element of ``values`` (any shape)."""
        flat = np.ravel(np.asarray(values, dtype=np.float64))
        self.count += flat.size
        finite = np.isfinite(flat)
        if finite.all():
            self._scaled += scaled_sum(flat)
            return
        self._scaled += scaled_sum(flat[finite])
        # inf + inf, -inf + -inf, inf - inf = NaN, NaN + x: the same in any order
        self._special += float(np.sum(flat[~finite]))

    def total(self) -> float:
        if self._special:  # NaN is true too
            return self._special
        try:
            return self._scaled / (1 << SCALE_BITS)  # int / int: rounded once, correctly
        except OverflowError:  # beyond the largest float
            return math.inf if self._scaled > 0 else -math.inf

    def mean(self) -> float:
        """NaN when nothing was added."""
        return self.total() / self.count if self.count else math.nan


class Moments:
    """Running aggregates of the finite rows of a signal, all columns pooled.

    ``lo``/``hi``: saturation limits (a row counts as saturated when any column is at or
    beyond one), and the range a row is inside when every column is within it (bounds included).
    """

    __slots__ = ("lo", "hi", "samples", "rows", "n", "total", "total_sq", "mean", "m2", "min", "max",
                 "max_abs", "first", "last", "delta_sq", "delta_n", "saturated", "inside")

    def __init__(self, lo: float = -math.inf, hi: float = math.inf) -> None:
        self.lo, self.hi = lo, hi
        self.samples = 0  #: rows fed, finite or not
        self.rows = 0  #: finite rows
        self.n = 0  #: values in the finite rows
        self.total = 0.0
        self.total_sq = 0.0
        self.mean = 0.0
        self.m2 = 0.0  #: sum of squared deviations from ``mean``
        self.min = math.inf
        self.max = -math.inf
        self.max_abs = -math.inf
        self.first: np.ndarray | None = None  #: the first finite row, shape (1,) or (1, columns)
        self.last: np.ndarray | None = None  #: the last finite row, shape (1,) or (1, columns)
        self.delta_sq = 0.0  #: sum of squared changes between consecutive finite rows
        self.delta_n = 0
        self.saturated = 0  #: finite rows with a column <= lo or >= hi
        self.inside = 0  #: finite rows with every column in [lo, hi]

    def add(self, values: np.ndarray) -> np.ndarray:
        """Feed a block; returns its finite rows."""
        self.samples += values.shape[0]
        flat = finite_rows(values)
        if flat.shape[0] == 0:
            return flat
        n = flat.size
        mean_b = float(np.mean(flat))
        m2_b = float(np.sum(np.square(flat - mean_b)))
        total = self.n + n
        delta = mean_b - self.mean
        self.mean += delta * n / total
        self.m2 += m2_b + delta * delta * self.n * n / total
        self.n = total
        self.rows += flat.shape[0]
        self.total += float(np.sum(flat))
        self.total_sq += float(np.sum(np.square(flat)))
        self.min = min(self.min, float(np.min(flat)))
        self.max = max(self.max, float(np.max(flat)))
        self.max_abs = max(self.max_abs, float(np.max(np.abs(flat))))
        d = np.diff(flat if self.last is None else np.concatenate([self.last, flat]), axis=0)
        self.delta_sq += float(np.sum(np.square(d)))
        self.delta_n += d.size
        if self.first is None:
            self.first = flat[:1].copy()
        self.last = flat[-1:].copy()
        sat = (flat <= self.lo) | (flat >= self.hi)
        self.saturated += int(np.count_nonzero(np.any(sat, axis=1) if sat.ndim == 2 else sat))
        inside = (flat >= self.lo) & (flat <= self.hi)
        self.inside += int(np.count_nonzero(np.all(inside, axis=1) if inside.ndim == 2 else inside))
        return flat


class SineFit:
    """Least squares of ``v ~ s sin(w t) + c cos(w t) + offset`` over the samples fed."""

    __slots__ = ("w", "r", "n")

    def __init__(self, freq_hz: float) -> None:
        self.w = 2.0 * math.pi * freq_hz
        self.r = np.zeros((0, 4))  #: triangular factor of [sin cos 1 v] (at most 4x4)
        self.n = 0

    def add(self, t_s: np.ndarray, v: np.ndarray) -> None:
        """Feed samples (finite ones: the caller filters)."""
        if t_s.size == 0:
            return
        a = np.column_stack([np.sin(self.w * t_s), np.cos(self.w * t_s), np.ones_like(t_s), v])
        self.r = _qr(np.vstack([self.r, a]), mode="r")
        self.n += t_s.size

    def phase_rad(self) -> float:
        """atan2(c, s) of the fit (as numpy.linalg.lstsq on every sample would give it)."""
        design, rhs = self.r[:, :3], self.r[:, 3]
        # lstsq's default cut-off for small singular values is eps * max(rows, columns): the
        # rows of the whole window, not of this factor
        rcond = np.finfo(float).eps * max(self.n, 3)
        coef = np.linalg.lstsq(design, rhs, rcond=rcond)[0]  # (s, c, offset)
        return math.atan2(float(coef[1]), float(coef[0]))
