"""What a board run records beyond every run's topics: the pins' traffic that no port carries,
and the board's figures per tick (hil/record/topics.py has the schemas).

* ``/hil/board/spi``: SPI0's words (MOSI, MISO) and the ADC's chip select;
* ``/hil/board/esc``: the ESC inputs read from the PWM and match-output pins;
* ``/hil/board/capture``: the PPM edges put on CAP1.0 and what Timer1 latched;
* ``/hil/board/tick``: busy cycles, load, interrupts and their worst latency, UART overruns.

The UARTs' bytes are the imu and telemetry ports' wire topics; the firmware's console lines
are ``/fc/log``. Each topic's message holds what happened since the previous tick, stamped at
its first item (``dt_ns`` from there).
"""

from __future__ import annotations

from typing import Any

from hil import clock
from hil.flight.board_loop import BoardTickLoop


class BoardRecorder:
    """Called after each tick, before the run logger closes the tick's batch; ``out`` is the
    recorder's batch (None: not recording, the records are only drained)."""

    def __init__(self, loop: BoardTickLoop, out: Any) -> None:
        self.loop = loop
        self.out = out

    def after_tick(self, k: int, t_ns: int) -> None:
        wiring = self.loop.wiring
        rec = wiring.take_records()
        changes, wiring.escs.changes = wiring.escs.changes, []
        out = self.out
        if out is None:
            return
        t_host = clock.monotonic_ns()
        if rec.spi or rec.cs:
            t0 = min([t for t, _, _ in rec.spi] + [t for t, _ in rec.cs])
            out.log("/hil/board/spi", max(t0, 0), {
                "t_ns": t0, "dt_ns": [t - t0 for t, _, _ in rec.spi], "mosi": [m for _, m, _ in rec.spi],
                "miso": [m for _, _, m in rec.spi], "cs_dt_ns": [t - t0 for t, _ in rec.cs],
                "cs_level": [lv for _, lv in rec.cs]}, t_host)
        if changes:
            t0 = changes[0][0]
            out.log("/hil/board/esc", max(t0, 0), {
                "t_ns": t0, "dt_ns": [t - t0 for t, _, _ in changes], "esc": [e for _, e, _ in changes],
                "width_us": [w for _, _, w in changes]}, t_host)
        if rec.edges or rec.captures:
            t0 = min([t for t, _ in rec.edges] + [t for t, _ in rec.captures])
            out.log("/hil/board/capture", max(t0, 0), {
                "t_ns": t0, "dt_ns": [t - t0 for t, _ in rec.edges], "level": [lv for _, lv in rec.edges],
                "cap_dt_ns": [t - t0 for t, _ in rec.captures], "cap_value": [v for _, v in rec.captures]}, t_host)
        fig = self.loop.tick_figures
        bus = wiring.bus
        out.log("/hil/board/tick", t_ns, {
            "t_ns": t_ns, "k": k, **{key: (int(v) if key != "load_pct" else v) for key, v in fig.items()},
            "uart0_rx_overruns": bus.uart0.counters["rx_overruns"],
            "uart1_rx_overruns": bus.uart1.counters["rx_overruns"]}, t_host)
