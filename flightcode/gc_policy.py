"""Garbage collection where the 400 Hz loop can afford it.

CPython collects when allocations pass a threshold, which lands in the middle of a sample's
processing at an arbitrary point: measured on the bench (30 s hover, thread CPU time), a
young collection took 0.07 ms, a middle one 0.7-1.0 ms, and a full one 12-19 ms, which is
five loop periods and every sample in them late. Flight code that must answer each sample
within 2.5 ms therefore:

1. collects everything once at the end of boot, before the IMU streams, and freezes the
   survivors (``gc.freeze``): modules,
   config, controllers and their matrices are never traversed again;
2. turns automatic collection off;
3. after each iteration (the ESC command is already written) collects the generation
   CPython's own thresholds would, so garbage is reclaimed at the same pace, off the
   sample-to-command path.

:meth:`LoopCollector.stop` gives the process its automatic collection back.
"""

from __future__ import annotations

import gc
from collections import Counter


class LoopCollector:
    """Deferred, threshold-driven collection for a periodic loop.

    Args:
        thresholds: (gen0 allocations, gen0 collections per gen1, gen1 per gen2), CPython's
            ``gc.get_threshold()`` meaning; default: the interpreter's current ones.
    """

    def __init__(self, thresholds: tuple[int, int, int] | None = None) -> None:
        t = gc.get_threshold() if thresholds is None else thresholds
        if len(t) != 3 or min(t) < 1:
            raise ValueError(f"thresholds must be three integers >= 1, got {t!r}")
        self.thresholds = (int(t[0]), int(t[1]), int(t[2]))
        #: collections made, by generation
        self.collections: Counter[int] = Counter()
        self._was_enabled: bool | None = None

    @property
    def running(self) -> bool:
        return self._was_enabled is not None

    def start(self) -> None:
        """After boot: collect, freeze what survives, and take over from automatic collection."""
        if self.running:
            return
        self._was_enabled = gc.isenabled()
        gc.collect()
        gc.freeze()
        gc.disable()

    def after_iteration(self) -> int | None:
        """Collect the generation CPython's thresholds call for, if any; returns it."""
        if not self.running:
            return None
        c0, c1, c2 = gc.get_count()
        t0, t1, t2 = self.thresholds
        if c0 <= t0:
            return None
        # the oldest generation over its threshold, as CPython's own collect_generations picks
        # (without its full-collection damping: the frozen boot objects are not traversed)
        generation = 2 if c2 > t2 else 1 if c1 > t1 else 0
        gc.collect(generation)
        self.collections[generation] += 1
        return generation

    def stop(self) -> None:
        """Unfreeze and give automatic collection back (if it was on before :meth:`start`)."""
        if not self.running:
            return
        gc.unfreeze()
        if self._was_enabled:
            gc.enable()
        self._was_enabled = None
