"""GDB's remote serial protocol, the framing only (sans-I/O): packets in and out.

A packet is ``$<data>#<two hex digits>``, the digits the sum of the data's bytes modulo 256;
``}`` escapes ``#``, ``$``, ``}`` and ``*`` in the data as ``}`` followed by the byte XOR
0x20; each packet is acknowledged with ``+`` (or ``-``: send it again); a lone 0x03 byte asks
the running target to stop (GDB manual, "Overview" of Appendix E, Remote Serial Protocol:
https://sourceware.org/gdb/current/onlinedocs/gdb.html/Overview.html).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

INTERRUPT_BYTE = 0x03
_ESCAPE = 0x7D
_ESCAPED = frozenset(b"#$}*")


class Event(Enum):
    """What arrived besides a packet."""

    INTERRUPT = "interrupt"  #: 0x03 (Ctrl-C in GDB)
    ACK = "ack"  #: +
    NAK = "nak"  #: - : the last packet sent arrived damaged


@dataclass(frozen=True)
class Packet:
    """One packet's data, unescaped."""

    data: bytes


def checksum(data: bytes) -> int:
    return sum(data) & 0xFF


def escape(data: bytes) -> bytes:
    out = bytearray()
    for b in data:
        if b in _ESCAPED:
            out += bytes((_ESCAPE, b ^ 0x20))
        else:
            out.append(b)
    return bytes(out)


def unescape(data: bytes) -> bytes:
    out = bytearray()
    it = iter(data)
    for b in it:
        if b == _ESCAPE:
            nxt = next(it, None)
            if nxt is not None:
                out.append(nxt ^ 0x20)
        else:
            out.append(b)
    return bytes(out)


def encode(data: bytes) -> bytes:
    """``data`` as one packet on the wire."""
    body = escape(data)
    return b"$" + body + b"#" + f"{checksum(body):02x}".encode()


class Decoder:
    """Bytes from the client in, events out; a packet with a bad checksum is dropped and
    answered ``-`` (``nak_due``), as the protocol asks."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self._in_packet = False
        self.nak_due = 0  #: ``-`` replies owed for damaged packets
        self.dropped = 0  #: bytes outside any packet that mean nothing (line noise)

    def feed(self, data: bytes) -> list[Packet | Event]:
        out: list[Packet | Event] = []
        for b in data:
            if not self._in_packet:
                if b == ord("$"):
                    self._in_packet = True
                    self._buf.clear()
                elif b == INTERRUPT_BYTE:
                    out.append(Event.INTERRUPT)
                elif b == ord("+"):
                    out.append(Event.ACK)
                elif b == ord("-"):
                    out.append(Event.NAK)
                else:
                    self.dropped += 1
                continue
            self._buf.append(b)
            if len(self._buf) >= 3 and self._buf[-3] == ord("#") and not self._escaped_at(len(self._buf) - 3):
                body, digits = bytes(self._buf[:-3]), bytes(self._buf[-2:])
                self._in_packet = False
                self._buf.clear()
                try:
                    good = int(digits, 16) == checksum(body)
                except ValueError:
                    good = False
                if good:
                    out.append(Packet(unescape(body)))
                else:
                    self.nak_due += 1
            elif b == ord("$") and not self._escaped_at(len(self._buf) - 1):
                self._buf.clear()  # a new packet began inside a broken one: start again
        return out

    def _escaped_at(self, i: int) -> bool:
        """Whether the byte at ``i`` of the packet's body follows an escape."""
        n = 0
        j = i - 1
        while j >= 0 and self._buf[j] == _ESCAPE:
            n += 1
            j -= 1
        return n % 2 == 1
