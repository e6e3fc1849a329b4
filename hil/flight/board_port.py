"""A rig port whose far end is a UART of the emulated LPC2148, not a pty.

On a board run the XSENS and the XBee still talk through ports (:class:`BoardPort`), so that
everything the bench does with a port's bytes keeps working: the wire taps record them as
``/hil/wire/<port>/<tx|rx>``, the wire faults filter them (``DeviceSet.wire_filters``), the
device models parse them. What differs is the client: bytes written to the port go onto the
UART's RXD pin at the board's current cycle (``to_pins``), paced by the device's own baud
rate and sampled by the UART model; bytes the firmware's UART sends come back through
:meth:`BoardPort.from_pins` at the sim time they left the TXD pin.

The line settings the device models see (``on_line``) are the UART's programmed rate: the
device's own rate when the divisor gives it within ``BAUD_TOLERANCE`` (a UART receiver
samples a frame right within about 2 %), else the programmed rate, rounded, which the device
models take as a mismatch as they would on a pty.
"""

from __future__ import annotations

from collections.abc import Callable

from hil.transport.base import Direction, LineSettings, Port

#: the relative rate error within which a UART frame is sampled right (half a bit over ten bits,
#: shared between the two ends)
BAUD_TOLERANCE = 0.02


class BoardPort(Port):
    """Device <-> UART ``uart`` of the board. ``to_pins(data)`` puts device bytes on the RXD
    line now; ``device_baud()`` is the rate the device sends at."""

    def __init__(self, name: str, uart: int, to_pins: Callable[[bytes], None]) -> None:
        super().__init__(name)
        self.uart = uart
        self._to_pins = to_pins
        self._baud: int | None = None

    def write(self, data: bytes) -> int:
        if not data:
            return 0
        self.stats.writes += 1
        self.stats.bytes_tx += len(data)
        self._tap(Direction.TX, data, self.sim_time())
        self._to_pins(data)
        return len(data)

    async def write_confirmed(self, data: bytes, timeout_s: float = 0.05) -> bool:
        self.write(data)
        return True

    def write_tracked(self, data: bytes) -> int:
        self.write(data)
        return 0

    async def confirm(self, want: int, timeout_s: float = 0.05) -> bool:
        return True

    def close(self) -> None:
        pass

    def client_consumed(self) -> int | None:
        return None  # the UART's FIFO and the firmware's ring are the client's: see the board's figures

    # -- the board's side -------------------------------------------------------------------
    def from_pins(self, data: bytes, t_ns: int) -> None:
        """Bytes the UART sent on its TXD pin, the last of them done at sim ``t_ns``."""
        self.stats.bytes_rx += len(data)
        self.stats.reads += 1
        self._tap(Direction.RX, data, t_ns)
        self.on_data(data, t_ns)

    def programmed(self, baud: float, device_baud: int) -> None:
        """The firmware set the UART to ``baud`` bit/s; the device runs at ``device_baud``."""
        seen = device_baud if abs(baud - device_baud) <= BAUD_TOLERANCE * device_baud else round(baud)
        if seen != self._baud:
            first = self._baud is None
            self._baud = seen
            self._line_changed(LineSettings(seen, opened=first))
