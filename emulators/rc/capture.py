"""Timer-capture front-end: PPM edges -> 6-byte capture records on a serial line.

The real part is a small MCU whose 16-bit timer runs at 1 MHz and captures every edge of
the PPM line; each capture is sent to the host as one record (format fixed in
docs/rc-capture-format.md)::

    A5 | seq u8 | flags | capture lo | capture hi | CRC-8
         flags bit0 = pin level after the edge, bit1 = a capture was lost before this one

CRC-8: polynomial 0x07, init 0x00, no reflection, no final xor, over bytes 1..4.

Captures are lost (and the next record flagged) when an edge follows the previous
capture closer than the interrupt latency, or when the record FIFO in front of the UART
is full: the FIFO is modelled by a virtual UART that sends records back to back at the
configured line rate. The bytes themselves are released at the edge time (a pty has no
line rate; the bench wants every record due by a tick delivered with that tick).
"""

from __future__ import annotations

import struct
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from enum import IntEnum, IntFlag, unique

from emulators.base import DeviceEvent
from emulators.rc.oneway import OneWayDevice
from emulators.rc.params import CaptureParams
from emulators.rc.ppm import PpmEdge

NS_PER_US = 1_000
NS_PER_S = 1_000_000_000


@unique
class CaptureWire(IntEnum):
    """Wire constants of the capture record."""

    SYNC = 0xA5
    RECORD_LEN = 6
    CRC_POLY = 0x07
    TIMER_MODULUS = 0x10000


@unique
class CaptureFlag(IntFlag):
    """Bits of the record's flags byte."""

    LEVEL_HIGH = 0x01
    OVERRUN = 0x02


def _crc8_table(poly: int) -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ poly) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC8_TABLE = _crc8_table(CaptureWire.CRC_POLY)


def crc8(data: bytes) -> int:
    """CRC-8/SMBUS: polynomial 0x07, init 0x00, MSB first, no final xor (check("123456789") = 0xF4)."""
    crc = 0
    for b in data:
        crc = _CRC8_TABLE[crc ^ b]
    return crc


@dataclass(frozen=True)
class CaptureRecord:
    """One decoded record: ``seq`` 0..255, ``level`` pin level after the edge, ``overrun``
    a capture was lost before this one, ``capture_us`` 16-bit timer value (us, wraps)."""

    seq: int
    level: bool
    overrun: bool
    capture_us: int


def pack_record(rec: CaptureRecord) -> bytes:
    """The 6 wire bytes of ``rec``."""
    flags = (CaptureFlag.LEVEL_HIGH if rec.level else 0) | (CaptureFlag.OVERRUN if rec.overrun else 0)
    body = bytes((rec.seq & 0xFF, int(flags), rec.capture_us & 0xFF, (rec.capture_us >> 8) & 0xFF))
    return bytes((CaptureWire.SYNC,)) + body + bytes((crc8(body),))


_SYNC = int(CaptureWire.SYNC)
_LEVEL_HIGH = int(CaptureFlag.LEVEL_HIGH)
_OVERRUN = int(CaptureFlag.OVERRUN)
_RECORD = struct.Struct("6B")


def pack_fields(seq: int, level: bool, overrun: bool, capture_us: int) -> bytes:
    """:func:`pack_record` of ``CaptureRecord(seq, level, overrun, capture_us)`` without
    building the record (the per-edge path): same bytes, the CRC unrolled over the table."""
    seq &= 0xFF
    flags = (_LEVEL_HIGH if level else 0) | (_OVERRUN if overrun else 0)
    lo, hi = capture_us & 0xFF, (capture_us >> 8) & 0xFF
    t = _CRC8_TABLE
    return _RECORD.pack(_SYNC, seq, flags, lo, hi, t[t[t[t[seq] ^ flags] ^ lo] ^ hi])


def unpack_record(data: bytes) -> CaptureRecord | None:
    """Decode 6 bytes; None if the sync byte, reserved flag bits or CRC are wrong."""
    if len(data) != CaptureWire.RECORD_LEN or data[0] != CaptureWire.SYNC:
        return None
    if crc8(data[1:5]) != data[5] or data[2] & ~0x03:
        return None
    return CaptureRecord(data[1], bool(data[2] & CaptureFlag.LEVEL_HIGH), bool(data[2] & CaptureFlag.OVERRUN),
                         data[3] | (data[4] << 8))


@dataclass(frozen=True)
class CaptureLost(DeviceEvent):
    """An edge at ``t_ns`` was not captured; ``reason`` is "latency" or "fifo_full"."""

    reason: str


class CaptureFrontEnd(OneWayDevice):
    """The capture MCU as a byte device on the ``rc`` port.

    The bench feeds PPM edges (:meth:`feed_edges`, in time order, possibly ahead of sim
    time) and calls :meth:`advance`; a record becomes output once sim time reaches its
    edge.
    """

    name = "rc"

    def __init__(self, params: CaptureParams) -> None:
        super().__init__()
        self.params = params
        self.baud_bps = params.baud
        self._record_ns = params.bits_per_byte * CaptureWire.RECORD_LEN * NS_PER_S // params.baud
        self._seq = 0
        self._overrun = False
        self._last_capture_ns: int | None = None
        self._last_edge_ns = -1
        self._uart_free_ns = 0
        #: Records not yet released: (edge t_ns, bytes).
        self._scheduled: deque[tuple[int, bytes]] = deque()
        #: Virtual UART start times of recent records, to know the FIFO occupancy.
        self._uart_starts: deque[int] = deque()

    def timer_us(self, t_ns: int) -> int:
        """The 16-bit 1 MHz timer value at sim time ``t_ns``."""
        return (t_ns // NS_PER_US + self.params.timer_offset_us) % CaptureWire.TIMER_MODULUS

    def feed_edges(self, edges: Iterable[PpmEdge]) -> None:
        """Capture ``edges`` (non-decreasing times); records are released by :meth:`advance`."""
        p = self.params
        counters, uart_starts = self.counters, self._uart_starts
        min_interval_ns = p.min_capture_interval_us * NS_PER_US
        for edge in edges:
            t = edge.t_ns
            if t < self._last_edge_ns:
                counters["edges_out_of_order"] += 1
                continue
            self._last_edge_ns = t
            counters["edges"] += 1
            if self._last_capture_ns is not None and t - self._last_capture_ns < min_interval_ns:
                self._lose(t, "latency")
                continue
            while uart_starts and uart_starts[0] <= t:
                uart_starts.popleft()  # already shifted out of the FIFO
            if len(uart_starts) >= p.fifo_records:
                self._lose(t, "fifo_full")
                continue
            self._last_capture_ns = t
            record = pack_fields(self._seq, edge.level, self._overrun, self.timer_us(t))
            self._seq = (self._seq + 1) & 0xFF
            self._overrun = False
            start = max(t, self._uart_free_ns)
            self._uart_free_ns = start + self._record_ns
            if start > t:
                uart_starts.append(start)
            self._scheduled.append((t, record))

    def _lose(self, t_ns: int, reason: str) -> None:
        self._overrun = True
        self.counters[f"captures_lost_{reason}"] += 1
        self._event(CaptureLost(t_ns, reason))

    def advance(self, t_ns: int) -> None:
        """Release the records of edges up to ``t_ns``."""
        while self._scheduled and self._scheduled[0][0] <= t_ns:
            _, data = self._scheduled.popleft()
            self._send(data)
            self.counters["records"] += 1
