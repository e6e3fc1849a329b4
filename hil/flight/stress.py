"""Timing stress for ``hil run``: how close is the 400 Hz loop to missing?

* ``CpuHog(n)``: n busy processes beside the flight code for the length of the run (they
  compete for the 2 cores the bench and the flight code share);
* the ADC bridge's reply delay (``DeviceSet.adc_reply_delay_ns``): every Bus Pirate reply
  is held back this long in wall time, like a slow USB-serial bridge, which adds straight
  to the flight code's response time.

The figures to watch are the response latency p99/max against the 2.5 ms budget and, in
realtime mode, the pacer's lateness (``hil run`` summary, ``hil timing LOG``).
"""

from __future__ import annotations

import subprocess
import sys
from types import TracebackType

_HOG = "while True:\n    pass\n"


class CpuHog:
    """``with CpuHog(2): ...`` runs 2 CPU-bound processes for the body of the block."""

    def __init__(self, n: int) -> None:
        self.n = max(0, n)
        self.procs: list[subprocess.Popen[bytes]] = []

    def __enter__(self) -> CpuHog:
        self.procs = [
            subprocess.Popen([sys.executable, "-c", _HOG], stdin=subprocess.DEVNULL) for _ in range(self.n)
        ]
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait()
        self.procs = []
