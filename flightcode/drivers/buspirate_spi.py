"""The flight code's SPI bridge on a Bus Pirate v3 in binary SPI mode: entry at boot, the
transfers of every sample, and re-entry in flight. The protocol and its entry sequence (sans-I/O)
are in :mod:`flightcode.drivers.buspirate_protocol`.

Transfers: every command's reply has a fixed length, so a whole sample's conversions go out
in one write and come back in one read of exactly that length: ``02 12 a b c 03`` per 3-byte
transfer answers ``01 01 x y z 01``. The driver counts the bytes it is still owed: a reply
that misses the read timeout is *late*, not lost; its remaining bytes are collected (and their
ack pattern checked) before the next write, so a late reply costs one sample's data and is
never read as the next sample's. Only a reply of the wrong shape, or one that does not arrive
within ``reply_timeout_s``, starts a re-entry, which in flight runs one non-blocking step per
sample (:meth:`BusPirateSpi.transfer_encoded`) instead of stalling the loop. After a garbled
reply (how much of it is still to come is unknown) the re-entry waits ``reply_timeout_s``
first: a reply later than that counts as lost, so none can be mistaken for a later sample's.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from enum import Enum, unique

from flightcode.drivers.base import DeviceError, SerialLike, read_waiting
from flightcode.drivers.buspirate_protocol import (
    SPEED_CODES,
    EntrySequence,
    EntryState,
    acks_ok,
    decode_transfers,
    encode_transfers,
    entry_script,
)
from flightcode.log import Logger


@unique
class LinkState(Enum):
    """Where the bridge is, seen from the flight code."""

    READY = "ready"  # in SPI mode, no reply outstanding
    REPLY_PENDING = "reply_pending"  # a reply missed the read timeout: its remaining bytes are owed
    ENTERING = "entering"  # a re-entry is in progress (one non-blocking step per sample)
    WAITING = "waiting"  # a re-entry failed: the next one starts after the resync interval


class BusPirateSpi:
    """The Bus Pirate on ``port`` (115200 8N1, port read timeout = the per-sample reply wait).

    Args:
        speed_hz: SPI clock, one of :data:`SPEED_CODES` (MCP3204: <= 2 MHz at 5 V).
        entry_attempts: full entry sequences tried at boot before giving up.
        reply_timeout_s: longest wait for each entry reply (boot and in flight) and for the
            rest of a late transfer reply, s (wall clock).
        quiet_s: the line must be quiet this long after the entry zeros, s (wall clock).
        resync_interval_ns: after a failed in-flight re-entry, the next starts this much sensor
            time later, ns.
        clock: monotonic seconds (``time.monotonic``; tests pass a fake).

    Counters: ``requests`` (transfer writes), ``transfers`` (good replies), ``short``/``bad_ack``
    (malformed replies), ``late_replies`` (missed the read timeout) and
    ``late_replies_discarded`` (collected later and thrown away), ``replies_lost`` (owed bytes
    that never came), ``unexpected_input`` (unowed bytes flushed before a write),
    ``sync_lost_<reason>``, ``resyncs`` (in-flight re-entries started), ``resync_failures``.
    """

    name = "adc"

    def __init__(self, port: SerialLike, *, speed_hz: int, entry_attempts: int, reply_timeout_s: float,
                 quiet_s: float, resync_interval_ns: int, log: Logger,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if speed_hz not in SPEED_CODES:
            raise ValueError(f"SPI speed {speed_hz} Hz is not one of {sorted(SPEED_CODES)}")
        self.port = port
        self.speed_hz = speed_hz
        self.entry_attempts = entry_attempts
        self.reply_timeout_s = reply_timeout_s
        self.quiet_s = quiet_s
        self.resync_interval_ns = resync_interval_ns
        self.log = log
        self.clock = clock
        self.counters: Counter[str] = Counter()
        self.state = LinkState.WAITING  # until :meth:`enter_spi` (or the first transfer) enters
        self._script = entry_script(speed_hz)
        self._entry: EntrySequence | None = None
        self._retry_ns: int | None = None  # WAITING: sensor time of the next attempt (None: at once)
        self._partial = bytearray()  # REPLY_PENDING: what came of the late reply so far
        self._owed = 0
        self._lengths: tuple[int, ...] = ()
        self._pending_since = 0.0
        self._stale_until = 0.0  # no re-entry before this (clock): a garbled reply's rest may come

    @property
    def in_sync(self) -> bool:
        """True when a transfer can go out now."""
        return self.state is LinkState.READY

    # -- entry ------------------------------------------------------------------------------
    def _begin_entry(self) -> EntrySequence:
        seq = EntrySequence(self._script, self.quiet_s, self.reply_timeout_s)
        self.port.reset_input_buffer()
        self.port.write(seq.start(self.clock()))
        self._entry = seq
        self.state = LinkState.ENTERING
        return seq

    def _entry_step(self, seq: EntrySequence, data: bytes) -> None:
        flush, out = seq.step(data, self.clock())
        if flush:
            self.port.reset_input_buffer()
        if out:
            self.port.write(out)

    def enter_spi(self) -> None:
        """Boot: entry with retries, blocking; DeviceError naming the adc on failure."""
        reason = "not tried"
        port = self.port
        for attempt in range(1, self.entry_attempts + 1):
            seq = self._begin_entry()
            while seq.state in (EntryState.DRAIN, EntryState.EXCHANGE):
                n = port.in_waiting
                self._entry_step(seq, port.read(n if n else 1))  # in silence waits the port timeout
            if seq.state is EntryState.DONE:
                self.state = LinkState.READY
                self._entry = None
                self.log.info("adc.spi_mode", attempts=attempt, speed_hz=self.speed_hz, drained=seq.drained)
                return
            reason = seq.reason
            self.log.warning("adc.entry_retry", attempt=attempt, reason=reason)
        raise DeviceError(self.name, f"Bus Pirate did not enter binary SPI mode after "
                                     f"{self.entry_attempts} attempt(s): {reason}")

    def lose_sync(self, reason: str, *, reply_in_flight: bool = False) -> None:
        """The data are wrong (a bad reply, a lost one, the MCP3204's null bit): re-enter;
        counted as ``sync_lost_<reason>``.

        ``reply_in_flight``: part of a transfer reply may still be on its way (the reply was
        garbled, so how much of it came is unknown). A late reply has the shape of a good one
        and would be read as the data of a later sample, so the re-entry waits until
        ``reply_timeout_s`` after this moment (a reply later than that is lost by definition)
        and then drains the line as usual.
        """
        self.counters["sync_lost_" + reason] += 1
        self.state = LinkState.WAITING
        self._retry_ns = None
        if reply_in_flight:
            self._stale_until = self.clock() + self.reply_timeout_s

    def _poll_entry(self, t_ns: int) -> bool:
        """One non-blocking step of the in-flight re-entry; True once the bridge is ready."""
        if self.state is LinkState.WAITING:
            if self._retry_ns is not None and t_ns < self._retry_ns:
                return False
            if self.clock() < self._stale_until:
                self.counters["samples_waiting_stale"] += 1
                return False
            self.counters["resyncs"] += 1
            self._begin_entry()
            return False  # replies come later: the next samples poll them
        seq = self._entry
        assert seq is not None
        self._entry_step(seq, read_waiting(self.port))
        if seq.state is EntryState.DONE:
            self.state = LinkState.READY
            self._entry = None
            self.log.info("adc.resynced", resyncs=self.counters["resyncs"], drained=seq.drained)
            return True
        if seq.state is EntryState.FAILED:
            self.counters["resync_failures"] += 1
            n_fail = self.counters["resync_failures"]
            if n_fail & (n_fail - 1) == 0:  # 1st, 2nd, 4th, ...: a dead bridge must not flood the log
                self.log.warning("adc.resync_failed", failures=n_fail, reason=seq.reason)
            self.state = LinkState.WAITING
            self._retry_ns = t_ns + self.resync_interval_ns
            self._entry = None
        return False

    # -- transfers --------------------------------------------------------------------------
    def _collect_late(self) -> bool:
        """REPLY_PENDING: take the owed bytes that have arrived; True once the line is clear."""
        port = self.port
        n = port.in_waiting
        if n:
            got = port.read(min(n, self._owed))
            self._partial += got
            self._owed -= len(got)
        if self._owed:
            if self.clock() - self._pending_since >= self.reply_timeout_s:
                self.counters["replies_lost"] += 1
                self.lose_sync("reply_lost")
            return False
        if decode_transfers(bytes(self._partial), self._lengths) == "bad_ack":
            self.counters["bad_ack"] += 1
            self.lose_sync("bad_late_reply", reply_in_flight=True)
            return False
        self.counters["late_replies_discarded"] += 1
        self.state = LinkState.READY
        return True

    def transfer(self, frames: Sequence[bytes], t_ns: int = 0) -> list[bytes] | None:
        """All ``frames`` as CS-framed bulk transfers: one write, one read; None this sample.

        See :meth:`transfer_encoded`.
        """
        return self.transfer_encoded(encode_transfers(frames), tuple(len(f) for f in frames), t_ns)

    def transfer_encoded(self, wire: bytes, lengths: tuple[int, ...], t_ns: int) -> list[bytes] | None:
        """:meth:`transfer` with the write already built by :func:`encode_transfers` (the
        per-sample path: the same four conversions every sample). ``t_ns`` is sensor time.

        Returns the MISO bytes of each transfer, or None when this sample has no data: the
        previous reply is still owed, a re-entry is in progress, the request went out short
        (the port does not block on writes; counted ``short_writes``: the bridge is
        re-entered), or this reply was short (counted ``late_replies``: its rest is collected
        at the next sample) or malformed (counted ``bad_ack``: the bridge is re-entered).
        Blocks at most the port's read timeout.
        """
        state = self.state
        if state is LinkState.REPLY_PENDING and not self._collect_late():
            return None
        if state in (LinkState.ENTERING, LinkState.WAITING) and not self._poll_entry(t_ns):
            return None
        port = self.port
        if port.in_waiting:  # nothing is owed, so these bytes are junk: never let them shift a reply
            self.counters["unexpected_input"] += 1
            port.reset_input_buffer()
        written = port.write(wire)
        self.counters["requests"] += 1
        if written is not None and written < len(wire):  # the port is non-blocking
            self.counters["short_writes"] += 1
            self.lose_sync("short_write", reply_in_flight=True)  # the bridge holds a torn request
            return None
        size = sum(n + 3 for n in lengths)
        reply = port.read(size)
        if len(reply) == size:
            result = decode_transfers(reply, lengths)
            if not isinstance(result, str):
                self.counters["transfers"] += 1
                return result
            self.counters[result] += 1
            self.lose_sync("bad_reply", reply_in_flight=True)
            return None
        if not acks_ok(reply, lengths):
            self.counters["bad_ack"] += 1
            self.lose_sync("bad_reply", reply_in_flight=True)
            return None
        # Late, not lost: the rest is owed and collected before the next write.
        self.counters["late_replies"] += 1
        self.state = LinkState.REPLY_PENDING
        self._partial = bytearray(reply)
        self._owed = size - len(reply)
        self._lengths = lengths
        self._pending_since = self.clock()
        return None
