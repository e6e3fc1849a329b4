"""CCLK cycles, PCLK ticks and nanoseconds, piecewise: the PLL and the APB divider change the
ratios while the firmware runs, and each change starts a new segment at the cycle it happens.

All arithmetic is on integers (clock rates in whole Hz), so a run's times are exact and
reproducible.
"""

from __future__ import annotations

NS_PER_S = 1_000_000_000


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


class Timebase:
    """The current segment of each ratio: cycle ``c0`` was PCLK tick ``p0`` and ``t0_ns``."""

    def __init__(self, cclk_hz: int, pclk_div: int) -> None:
        self._pc0 = 0
        self._p0 = 0
        self.pclk_div = pclk_div
        self._nc0 = 0
        self._t0_ns = 0
        self.cclk_hz = cclk_hz

    @property
    def pclk_hz(self) -> float:
        return self.cclk_hz / self.pclk_div

    def pclk_at(self, cycle: int) -> int:
        """PCLK ticks elapsed at ``cycle``."""
        return self._p0 + (cycle - self._pc0) // self.pclk_div

    def pclk_exact(self, cycle: int) -> float:
        """The PCLK time of ``cycle``, with the fraction of a tick."""
        return self._p0 + (cycle - self._pc0) / self.pclk_div

    def cycle_of_pclk(self, tick: float) -> int:
        """The first cycle at or after PCLK time ``tick``."""
        return self._pc0 + int(-(-(tick - self._p0) * self.pclk_div // 1))

    def ns_at(self, cycle: int) -> int:
        """Nanoseconds since reset at ``cycle`` (rounded down)."""
        return self._t0_ns + (cycle - self._nc0) * NS_PER_S // self.cclk_hz

    def cycle_at_ns(self, t_ns: int) -> int:
        """The first cycle at or after ``t_ns``."""
        return self._nc0 + _ceil_div((t_ns - self._t0_ns) * self.cclk_hz, NS_PER_S)

    def set_pclk_div(self, cycle: int, div: int) -> None:
        if div != self.pclk_div:
            self._p0, self._pc0, self.pclk_div = self.pclk_at(cycle), cycle, div

    def set_cclk_hz(self, cycle: int, hz: int) -> None:
        if hz != self.cclk_hz:
            self._t0_ns, self._nc0, self.cclk_hz = self.ns_at(cycle), cycle, hz
