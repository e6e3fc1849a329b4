"""What the RC port's two front ends share: they only talk. Host bytes are counted and ignored,
and a host at another line rate than the device's is counted (a real host would read garbage)."""

from __future__ import annotations

from emulators.base import ByteDevice


class OneWayDevice(ByteDevice):
    """A byte device that only sends, at ``baud_bps`` (bit/s, set by the subclass)."""

    baud_bps: int

    def receive(self, data: bytes, t_ns: int) -> None:
        """The device takes no commands: host bytes are counted (``rx_ignored_bytes``) and ignored."""
        self.counters["rx_ignored_bytes"] += len(data)

    def line_settings_changed(self, baud: int, t_ns: int) -> None:
        """Count a host rate other than ``baud_bps`` (``baud_mismatch``)."""
        super().line_settings_changed(baud, t_ns)
        if baud != self.baud_bps:
            self.counters["baud_mismatch"] += 1
