"""Output configuration: what the device applies, and when each item goes out.

mk4 SetOutputConfiguration (MT0605P §5.3.3: "the response message contains a list with the
same format, but with the values actually used by the device"). The emulator's rules,
applied entry by entry:

* An XDI this device does not have (or coordinate bits 0xC) is not applied and is left out
  of the reply; XDI 0x0000 (ethz's "clear" entry) therefore yields an empty list.
* Integer items (counters, time, status, pressure) ignore the format bits; the reply shows
  them cleared. A repeated data type keeps its first entry.
* Frequency 0xFFFF or 0 means "every packet": kept as 0xFFFF for counters, time and status,
  and the item's maximum for the others.
* Other frequencies are capped at the item's maximum (orientation 400 Hz, inertial 2000 Hz,
  magnetic field 100 Hz, pressure 50 Hz; ethz usage text) and at the sample grid
  (``sample_rate_hz`` = the bench tick), then lowered to the nearest rate that divides the
  grid (mk4 outputs exist only at integer divisions of 400 Hz, MT0605P §4.10): a request
  for 300 Hz is applied, and acknowledged, as 200 Hz. A client that compares the reply with
  its request (as XDA and the bench's flight code do) sees the refusal.

Legacy (SetPeriod/SetOutputSkipFactor): one message every ``period * (skip + 1)`` / 115200 s;
periods outside 225..1152 (ethz usage text), or whose rate is not on the sample grid, are
refused with Error 0x03 (INVALIDPERIOD); skip factor 0xFFFF means polled output only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from emulators.xsens.defs import (
    FREQ_EVERY_PACKET,
    MAX_STD_PAYLOAD,
    PERIOD_CLOCK_HZ,
    XDI,
    XDI_COORD_MASK,
    XDI_FORMAT_MASK,
    ErrorCode,
)
from emulators.xsens.mtdata2 import BYTES_PER_SCALAR, precision_of

MAX_ENTRIES = 32
LEGACY_PERIOD_MIN = 225
LEGACY_PERIOD_MAX = 1152
SKIP_POLLED = 0xFFFF


@dataclass(frozen=True)
class ItemInfo:
    """What the device knows about one data type."""

    max_hz: int
    scalars: int  #: floating values per sample; 0 for integer items
    int_bytes: int = 0  #: size of integer items
    every_packet: bool = False  #: 0xFFFF keeps its meaning "in every message"


ITEMS: dict[XDI, ItemInfo] = {
    XDI.TEMPERATURE: ItemInfo(400, 1),
    XDI.PACKET_COUNTER: ItemInfo(2000, 0, 2, True),
    XDI.SAMPLE_TIME_FINE: ItemInfo(2000, 0, 4, True),
    XDI.SAMPLE_TIME_COARSE: ItemInfo(2000, 0, 4, True),
    XDI.QUATERNION: ItemInfo(400, 4),
    XDI.ROTATION_MATRIX: ItemInfo(400, 9),
    XDI.EULER_ANGLES: ItemInfo(400, 3),
    XDI.BARO_PRESSURE: ItemInfo(50, 0, 4),
    XDI.DELTA_V: ItemInfo(400, 3),
    XDI.ACCELERATION: ItemInfo(2000, 3),
    XDI.FREE_ACCELERATION: ItemInfo(400, 3),
    XDI.RATE_OF_TURN: ItemInfo(2000, 3),
    XDI.DELTA_Q: ItemInfo(400, 4),
    XDI.MAGNETIC_FIELD: ItemInfo(100, 3),
    XDI.STATUS_BYTE: ItemInfo(2000, 0, 1, True),
    XDI.STATUS_WORD: ItemInfo(2000, 0, 4, True),
}


def base_type(xdi: int) -> XDI | None:
    """The data type of an XDI (format bits cleared), None if this device lacks it."""
    try:
        return XDI(xdi & ~XDI_FORMAT_MASK & 0xFFFF)
    except ValueError:
        return None


def item_data_size(xdi: int) -> int:
    """Bytes of one packet's data for an applied XDI."""
    info = ITEMS[XDI(xdi & ~XDI_FORMAT_MASK & 0xFFFF)]
    if info.scalars == 0:
        return info.int_bytes
    return info.scalars * BYTES_PER_SCALAR[precision_of(xdi)]


def coerce_rate(requested_hz: int, max_hz: int, grid_hz: int) -> int:
    """Highest rate <= min(requested, max, grid) that divides the grid (at least 1 Hz)."""
    cap = min(requested_hz, max_hz, grid_hz)
    for divider in range(max(1, -(-grid_hz // max(cap, 1))), grid_hz + 1):
        if grid_hz % divider == 0:
            return grid_hz // divider
    return 1


def apply_output_configuration(
    entries: Iterable[tuple[int, int]], grid_hz: int
) -> tuple[tuple[int, int], ...]:
    """The (XDI, Hz) list the device applies for a requested list (rules in the module doc)."""
    applied: list[tuple[int, int]] = []
    seen: set[XDI] = set()
    for xdi, freq in entries:
        kind = base_type(xdi)
        if kind is None or kind in seen:
            continue
        info = ITEMS[kind]
        if info.scalars == 0:
            xdi = int(kind)
        elif xdi & XDI_COORD_MASK == XDI_COORD_MASK:
            continue
        if freq in (0, FREQ_EVERY_PACKET):
            rate = FREQ_EVERY_PACKET if info.every_packet else min(info.max_hz, grid_hz)
        else:
            rate = coerce_rate(freq, info.max_hz, grid_hz)
        seen.add(kind)
        applied.append((xdi, rate))
    return tuple(applied)


def parse_entries(payload: bytes) -> tuple[tuple[tuple[int, int], ...], ErrorCode | None]:
    """Split a SetOutputConfiguration payload; an error code if it is malformed."""
    if len(payload) % 4:
        return (), ErrorCode.INVALID_MESSAGE
    n = len(payload) // 4
    if n > MAX_ENTRIES:
        return (), ErrorCode.INVALID_PARAM
    return tuple(
        (int.from_bytes(payload[4 * i : 4 * i + 2], "big"), int.from_bytes(payload[4 * i + 2 : 4 * i + 4], "big"))
        for i in range(n)
    ), None


def encode_entries(entries: Iterable[tuple[int, int]]) -> bytes:
    return b"".join(x.to_bytes(2, "big") + f.to_bytes(2, "big") for x, f in entries)


def frame_size(payload_len: int) -> int:
    """Bytes on the wire for a message with ``payload_len`` data bytes."""
    return payload_len + (5 if payload_len <= MAX_STD_PAYLOAD else 7)


@dataclass(frozen=True)
class Schedule:
    """When data messages go out and what each carries.

    ``period_ns`` is the message grid (instants t with t % period_ns == 0), None when the
    device does not stream. ``items`` pairs each applied XDI with its own period (None =
    in every message).
    """

    period_ns: int | None
    items: tuple[tuple[int, int | None], ...] = ()

    def due(self, t_ns: int) -> list[int]:
        return [xdi for xdi, p in self.items if p is None or t_ns % p == 0]

    def bytes_per_second(self, message_size: Callable[[int], int]) -> int:
        """Wire bytes in one second of streaming; ``message_size(t_ns)`` gives a frame's size."""
        if self.period_ns is None:
            return 0
        return sum(message_size(t) for t in range(0, 1_000_000_000, self.period_ns))


def mk4_schedule(applied: Iterable[tuple[int, int]], grid_hz: int) -> Schedule:
    """Streaming schedule of an applied MTData2 configuration."""
    items: list[tuple[int, int | None]] = []
    for xdi, freq in applied:
        items.append((xdi, None if freq == FREQ_EVERY_PACKET else 1_000_000_000 // freq))
    if not items:
        return Schedule(None)
    periods = [p for _, p in items if p is not None]
    period = math.gcd(*periods) if periods else 1_000_000_000 // grid_hz
    return Schedule(period, tuple(items))


def mtdata2_payload_size(xdis: Iterable[int]) -> int:
    return sum(3 + item_data_size(x) for x in xdis)


def legacy_period_error(period: int, skip: int, grid_hz: int) -> ErrorCode | None:
    """None if a legacy period/skip pair is accepted, else Error 0x03."""
    if not LEGACY_PERIOD_MIN <= period <= LEGACY_PERIOD_MAX:
        return ErrorCode.INVALID_PERIOD
    if skip != SKIP_POLLED and (period * (skip + 1) * grid_hz) % PERIOD_CLOCK_HZ:
        return ErrorCode.INVALID_PERIOD
    return None


def legacy_schedule(period: int, skip: int) -> Schedule:
    """One MTData every period * (skip + 1) / 115200 s; None period when polled."""
    if skip == SKIP_POLLED:
        return Schedule(None)
    return Schedule(period * (skip + 1) * 1_000_000_000 // PERIOD_CLOCK_HZ)

