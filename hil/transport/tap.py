"""Wire-tap sinks: where a port's (t_ns, direction, bytes) records go."""

from __future__ import annotations

from hil.transport.base import Direction, WireRecord


class WireCollector:
    """Keeps every record in memory (tests, short runs)."""

    def __init__(self) -> None:
        self.records: list[WireRecord] = []

    def __call__(self, record: WireRecord) -> None:
        self.records.append(record)

    def joined(self, port: str, direction: Direction) -> bytes:
        """All bytes of one port and direction, concatenated in order."""
        return b"".join(r.data for r in self.records if r.port == port and r.direction is direction)
