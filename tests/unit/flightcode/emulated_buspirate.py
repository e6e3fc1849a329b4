"""The real Bus Pirate + MCP3204 emulators behind an in-process, pyserial-like port whose
replies can arrive late, in fragments or with garbage, on a fake monotonic clock.

The port implements the calls the flight code makes (``read``, ``write``, ``in_waiting``,
``reset_input_buffer``, ``out_waiting``, ``close``) with pyserial's semantics: ``read(n)``
returns when ``n`` bytes have arrived or the read timeout has passed since the call, and the
fake clock moves on by exactly the time the call would have blocked. Nothing sleeps.

The MCP3204's input voltages depend on the sample time the test sets (:attr:`t_ns`), so a
code read for the wrong sample (a late reply taken as the current one) is always caught:
:func:`expected_codes` says what each sample must read.
"""

from __future__ import annotations

from collections.abc import Callable

from emulators.buspirate import BusPirate, BusPirateParams
from emulators.mcp3204 import Mcp3204, Mcp3204Params
from tests.unit.flightcode.fakes import FakeClock

__all__ = ["TICK_NS", "Delivery", "EmulatedBusPiratePort", "FakeClock", "expected_codes", "prompt"]

TICK_NS = 2_500_000
VREF_V = 5.0


def expected_codes(t_ns: int) -> tuple[int, int, int, int]:
    """The code each channel converts at sensor time ``t_ns``: different for every sample."""
    k = t_ns // TICK_NS
    return tuple((100 + 37 * k + 1000 * ch) % 4000 + 50 for ch in range(4))  # type: ignore[return-value]


def _sampler(channel: int, t_ns: int) -> float:
    # The middle of the code's bin: the ideal part reads exactly expected_codes.
    return (expected_codes(t_ns)[channel] + 0.5) * VREF_V / 4096


#: (write number, reply bytes, now) -> [(delivery time s, bytes), ...]
Delivery = Callable[[int, bytes, float], list[tuple[float, bytes]]]


def prompt(index: int, data: bytes, now_s: float) -> list[tuple[float, bytes]]:
    """Replies arrive 50 us after the write (a pty on an idle machine)."""
    return [(now_s + 50e-6, data)]


class EmulatedBusPiratePort:
    """A pyserial-like port wired to ``BusPirate(BusPirateParams(), Mcp3204(...))``.

    Args:
        clock: the fake clock (shared with the driver under test).
        timeout_s: the port's read timeout (the driver's per-sample reply wait), s.
        delivery: when each write's reply bytes reach the host (default :func:`prompt`).
    """

    def __init__(self, clock: FakeClock, *, timeout_s: float = 0.02, delivery: Delivery = prompt) -> None:
        self.clock = clock
        self.timeout = timeout_s
        self.delivery = delivery
        self.device = BusPirate(BusPirateParams(), Mcp3204(Mcp3204Params(vref_V=VREF_V), _sampler))
        self.device.line_settings_changed(115200, 0)
        self.device.take_output()  # the power-up banner: flushed by the host's open
        self.t_ns = 0  #: sensor time of the sample being read (the analog inputs follow it)
        self.writes: list[bytes] = []
        #: the next write takes only this many bytes (a full output buffer; the port is non-blocking)
        self.short_next: int | None = None
        self.flushes = 0
        self.discarded = 0  #: bytes thrown away by reset_input_buffer
        self._in_flight: list[tuple[float, bytes]] = []
        self._rx = bytearray()

    # -- delivery ------------------------------------------------------------------------
    def _arrive(self, until_s: float) -> None:
        keep = []
        for t_s, data in self._in_flight:
            if t_s <= until_s:
                self._rx += data
            else:
                keep.append((t_s, data))
        self._in_flight = keep

    def _next_arrival(self) -> float | None:
        return min((t for t, _ in self._in_flight), default=None)

    def inject(self, data: bytes, after_s: float = 0.0) -> None:
        """Line noise: ``data`` arrives ``after_s`` from now."""
        self._in_flight.append((self.clock() + after_s, data))

    @property
    def in_flight(self) -> int:
        """Bytes sent by the device that have not reached the host yet."""
        return sum(len(d) for _, d in self._in_flight)

    # -- pyserial calls ------------------------------------------------------------------------
    @property
    def in_waiting(self) -> int:
        self._arrive(self.clock())
        return len(self._rx)

    out_waiting = 0

    def read(self, size: int = 1) -> bytes:
        deadline = self.clock() + self.timeout
        self._arrive(self.clock())
        while len(self._rx) < size:
            t_next = self._next_arrival()
            if t_next is None or t_next > deadline:
                self.clock.now_s = max(self.clock.now_s, deadline)  # blocked the whole timeout
                break
            self.clock.now_s = max(self.clock.now_s, t_next)
            self._arrive(t_next)
        out = bytes(self._rx[:size])
        del self._rx[:size]
        return out

    def write(self, data: bytes) -> int:
        data = bytes(data)
        if self.short_next is not None:
            data, self.short_next = data[: self.short_next], None
        self.writes.append(data)
        self.device.receive(data, self.t_ns)
        reply = self.device.take_output()
        if reply:
            self._in_flight += self.delivery(len(self.writes) - 1, reply, self.clock())
        return len(data)

    def reset_input_buffer(self) -> None:
        self._arrive(self.clock())
        self.flushes += 1
        self.discarded += len(self._rx)
        self._rx.clear()

    def close(self) -> None:
        pass
