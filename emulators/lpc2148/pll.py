"""One PLL of the LPC2148 (UM10139 Rev. 4, §4.8: PLLCON, PLLCFG, PLLSTAT, PLLFEED).

PLLCON bit 0 PLLE (enable), bit 1 PLLC (connect); PLLCFG bits 4:0 MSEL (M - 1), bits 6:5
PSEL (P = 1, 2, 4, 8). Writes to PLLCON and PLLCFG take effect only after a valid feed: 0xAA
then 0x55 written to PLLFEED on consecutive APB accesses (any other APB access in between, or
another value, voids it). PLLSTAT reads the values in effect (bits 6:0 the configuration,
8 PLLE, 9 PLLC) and bit 10 PLOCK.

CCLK = M x Fosc while the PLL is enabled, connected and locked, else Fosc. The current
controlled oscillator (Fcco = CCLK x 2 x P) must be in 156-320 MHz: outside it the model never
locks (a firmware that waits for PLOCK waits forever, as on a part with a wrong PSEL).
Lock comes ``lock_us`` after the feed that enabled or changed the PLL. The manual gives no
lock time; the default (100 us) is a parameter, not a datasheet figure.
"""

from __future__ import annotations

import math

FCCO_MIN_HZ = 156e6
FCCO_MAX_HZ = 320e6
FEED_FIRST, FEED_SECOND = 0xAA, 0x55


class Pll:
    """PLL0 (the CPU clock) or PLL1 (USB); time in CCLK cycles."""

    def __init__(self, fosc_hz: float, lock_us: float) -> None:
        self.fosc_hz = fosc_hz
        self.lock_us = lock_us
        self.con_written = 0
        self.cfg_written = 0
        self.con = 0  #: in effect
        self.cfg = 0  #: in effect
        self.lock_at: int | None = None  #: cycle of lock; None: not locking
        self._aa_seq: int | None = None
        self.counters: dict[str, int] = {"feeds": 0, "bad_feeds": 0, "fcco_out_of_range": 0}

    @property
    def m(self) -> int:
        return (self.cfg & 0x1F) + 1

    @property
    def p(self) -> int:
        return 1 << ((self.cfg >> 5) & 3)

    def locked(self, cycle: int) -> bool:
        return bool(self.con & 1) and self.lock_at is not None and cycle >= self.lock_at

    def connected(self, cycle: int) -> bool:
        """PLLE, PLLC and PLOCK: the PLL's output is the clock."""
        return bool(self.con & 2) and self.locked(cycle)

    def output_hz(self, cycle: int) -> float:
        return self.fosc_hz * self.m if self.connected(cycle) else self.fosc_hz

    def stat(self, cycle: int) -> int:
        return (self.cfg & 0x7F) | (self.con & 3) << 8 | int(self.locked(cycle)) << 10

    def feed(self, value: int, apb_seq: int, cycle: int, cclk_hz: float) -> None:
        """A write of ``value`` to PLLFEED as APB access number ``apb_seq``."""
        if value == FEED_FIRST:
            self._aa_seq = apb_seq
            return
        valid = value == FEED_SECOND and self._aa_seq is not None and apb_seq == self._aa_seq + 1
        self._aa_seq = None
        if not valid:
            self.counters["bad_feeds"] += 1
            return
        self.counters["feeds"] += 1
        relock = (self.con_written & 1 and not self.con & 1) or (self.con & 1 and self.cfg_written != self.cfg)
        self.con, self.cfg = self.con_written & 3, self.cfg_written & 0x7F
        if not self.con & 1:
            self.lock_at = None
        elif relock or self.lock_at is None:
            fcco = self.fosc_hz * self.m * 2 * self.p
            if not FCCO_MIN_HZ <= fcco <= FCCO_MAX_HZ:
                self.counters["fcco_out_of_range"] += 1
                self.lock_at = None
            else:
                self.lock_at = cycle + math.ceil(self.lock_us * 1e-6 * cclk_hz)
