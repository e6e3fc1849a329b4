"""MCP3204 12-bit ADC (Microchip DS21298E) read through an SPI bridge, four channels a tick.

Framing: the datasheet's 3-byte transaction (Fig. 6-1, SPI mode 0,0; protocols.md 2):

=====  ============================  =================================
byte   MOSI                          MISO
=====  ============================  =================================
0      ``0000 01 S D2`` (S=1 single)  ignored (hi-Z)
1      ``D1 D0 xxxxxx``               ``? ? ? 0 B11 B10 B9 B8`` (bit 4 = null bit)
2      ``xxxx xxxx``                  ``B7 .. B0``
=====  ============================  =================================

so CH0..CH3 single-ended are ``06 00 00``, ``06 40 00``, ``06 80 00``, ``06 C0 00``.

:class:`Mcp3204Reader` sends all channels in one pipelined bridge write per tick. A failed
transaction (short reply, bad ack, null bit set) makes the tick's reading invalid (None);
the bridge is re-entered at the next tick, and after a failed re-entry only every
``resync_interval_ns`` of sensor time, so a dead ADC costs at most one bounded wait per
interval instead of one per tick.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from flightcode.drivers.buspirate_spi import BusPirateSpi, encode_transfers

RESOLUTION_CODES = 4096
START_BIT = 0x04
SINGLE_ENDED = 0x02
NULL_BIT = 0x10


def request(channel: int, single_ended: bool = True) -> bytes:
    """The 3 MOSI bytes converting ``channel`` (0..3)."""
    if not 0 <= channel <= 3:
        raise ValueError(f"MCP3204 channel {channel} (0..3)")
    return bytes((START_BIT | (SINGLE_ENDED if single_ended else 0), (channel & 0x3) << 6, 0x00))


def decode(miso: bytes) -> int | None:
    """The 12-bit code from the 3 MISO bytes; None if the null bit is not 0 or length wrong."""
    if len(miso) != 3 or miso[1] & NULL_BIT:
        return None
    return ((miso[1] & 0x0F) << 8) | miso[2]


class Mcp3204Reader:
    """Reads ``channels`` each tick through ``bridge``.

    Args:
        bridge: a bridge already in SPI mode (:meth:`BusPirateSpi.enter_spi`).
        channels: MCP3204 channel numbers in the order the codes are returned.
        resync_interval_ns: sensor time between re-entry attempts after one failed, ns.
        resync_timeout_s: wall-clock bound of one in-flight re-entry, s.
    """

    name = "adc"

    def __init__(self, bridge: BusPirateSpi, channels: Sequence[int], *, resync_interval_ns: int,
                 resync_timeout_s: float) -> None:
        self.bridge = bridge
        self.channels = tuple(channels)
        self._frames = [request(ch) for ch in self.channels]
        self._wire = encode_transfers(self._frames)
        self._lengths = [len(f) for f in self._frames]
        self.resync_interval_ns = resync_interval_ns
        self.resync_timeout_s = resync_timeout_s
        self.counters: Counter[str] = Counter()
        self._next_resync_ns: int | None = None

    def read_codes(self, t_ns: int) -> tuple[int, ...] | None:
        """Codes of all channels for the sample at sensor time ``t_ns``, or None this tick."""
        bridge = self.bridge
        if not bridge.in_sync:
            if self._next_resync_ns is not None and t_ns < self._next_resync_ns:
                self.counters["skipped_out_of_sync"] += 1
                return None
            if not bridge.resync(self.resync_timeout_s):
                self._next_resync_ns = t_ns + self.resync_interval_ns
                return None
        replies = bridge.transfer_encoded(self._wire, self._lengths)
        if replies is None:
            self.counters["failed_reads"] += 1
            self._next_resync_ns = None  # re-enter at the next tick
            return None
        codes = []
        for miso in replies:
            code = decode(miso)
            if code is None:
                self.counters["null_bit_errors"] += 1
                self.counters["failed_reads"] += 1
                bridge.in_sync = False  # wrong SPI mode or framing: re-apply the setup
                self._next_resync_ns = None
                return None
            codes.append(code)
        self.counters["reads"] += 1
        return tuple(codes)
