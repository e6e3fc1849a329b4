"""The radio channel between XBee modules: air time, latency, losses, retries, dropouts.

One shared 802.15.4 channel: packets go on the air one at a time in the order the modules
handed them over. An acknowledged unicast is retried (``mac_retries`` x (RR + 1) extra
attempts) until an attempt gets through; each failed attempt costs its air time, the ACK
wait and a random back-off. Broadcasts and no-ACK packets get one attempt and always
report success to the sender, as on the module. Everything is in sim time and seeded.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from emulators.base import DeviceEvent
from emulators.xbee.frames import TxStatus
from emulators.xbee.module import XBeeModule
from emulators.xbee.packets import NO_16BIT, RfPacket
from emulators.xbee.params import LinkParams

NS_PER_S = 1_000_000_000
PHY_OVERHEAD_BYTES = 6  # preamble 4, SFD 1, length 1
MAC_OVERHEAD_16 = 11  # frame control 2, seq 1, PAN 2, dest 2, src 2, FCS 2
ADDR64_EXTRA = 6  # each 64-bit address is 6 bytes longer than a 16-bit one
MAXSTREAM_HEADER = 2  # MM=0/2 adds Digi's header
ACK_NS = 352_000 + 192_000  # 11-byte ACK frame at 250 kbit/s + turnaround
ACK_WAIT_NS = 864_000  # macAckWaitDuration (54 symbols)
BACKOFF_UNIT_NS = 320_000  # aUnitBackoffPeriod


@dataclass(frozen=True, init=False)
class RfDelivered(DeviceEvent):
    """A packet of ``n_bytes`` from module ``src`` reached module ``dst`` at ``t_ns``."""

    src: str
    dst: str
    n_bytes: int
    attempts: int

    def __init__(self, t_ns: int, src: str, dst: str, n_bytes: int, attempts: int) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "src", src)
        object.__setattr__(self, "dst", dst)
        object.__setattr__(self, "n_bytes", n_bytes)
        object.__setattr__(self, "attempts", attempts)


@dataclass(frozen=True)
class RfFailed(DeviceEvent):
    """A packet of module ``src`` was not delivered (``reason``: "no_ack", "lost")."""

    src: str
    n_bytes: int
    reason: str


class RadioLink:
    """Connects the attached modules; call :meth:`advance` with non-decreasing sim time."""

    def __init__(self, params: LinkParams, rng: np.random.Generator) -> None:
        self.params = params
        self.rng = rng
        self.modules: list[XBeeModule] = []
        self._dropouts: list[tuple[int, int]] = [
            (int(s * NS_PER_S), int((s + d) * NS_PER_S)) for s, d in params.dropouts]
        self._loss_probability = params.loss_probability
        self._channel_free_ns = 0
        self._seq = 0
        #: (t_ns, seq, kind, payload): kind "deliver" (rx module, pkt, rssi) or "done" (tx module, tag, status).
        self._agenda: list[tuple[int, int, str, tuple[object, ...]]] = []
        self._events: list[DeviceEvent] = []
        self.counters: dict[str, int] = {"packets": 0, "delivered": 0, "attempts": 0, "failed": 0}

    def attach(self, module: XBeeModule) -> None:
        """Put ``module`` on this channel."""
        self.modules.append(module)

    # -- fault hooks ---------------------------------------------------------------------
    def inject_dropout(self, t_ns: int, duration_ns: int) -> None:
        """Nothing gets through in ``[t_ns, t_ns + duration_ns)`` (out of range)."""
        self._dropouts.append((t_ns, t_ns + duration_ns))

    def set_loss_probability(self, p: float) -> None:
        """Per-attempt loss probability from now on."""
        self._loss_probability = min(1.0, max(0.0, p))

    # -- time ----------------------------------------------------------------------------
    def advance(self, t_ns: int) -> None:
        """Take the modules' new packets, put them on the air, deliver what is due (a
        delivery may make a module answer, e.g. a remote AT command: that goes on too)."""
        while True:
            self._collect()
            if not self._agenda or self._agenda[0][0] > t_ns:
                return
            while self._agenda and self._agenda[0][0] <= t_ns:
                t, _, kind, args = heapq.heappop(self._agenda)
                if kind == "deliver":
                    rx, pkt, rssi = args
                    assert isinstance(rx, XBeeModule) and isinstance(pkt, RfPacket) and isinstance(rssi, float)
                    rx.air_receive(pkt, t, rssi)
                else:
                    tx, tag, status = args
                    assert isinstance(tx, XBeeModule) and isinstance(tag, int) and isinstance(status, TxStatus)
                    tx.air_tx_done(tag, status, t)

    def _collect(self) -> None:
        new: list[tuple[int, int, XBeeModule, RfPacket]] = []
        for i, m in enumerate(self.modules):
            for pkt in m.take_air_tx():
                new.append((pkt.t_ns, i, m, pkt))
        new.sort(key=lambda x: (x[0], x[1]))
        for _, _, m, pkt in new:
            self._schedule(m, pkt)

    def take_events(self) -> list[DeviceEvent]:
        """Drain delivery/failure events."""
        events, self._events = self._events, []
        return events

    def _push(self, t_ns: int, kind: str, args: tuple[object, ...]) -> None:
        self._seq += 1
        heapq.heappush(self._agenda, (t_ns, self._seq, kind, args))

    def _in_dropout(self, t_ns: int) -> bool:
        return any(a <= t_ns < b for a, b in self._dropouts)

    def air_time_ns(self, pkt: RfPacket) -> int:
        """Time on air of one transmission of ``pkt``."""
        n = PHY_OVERHEAD_BYTES + MAC_OVERHEAD_16 + MAXSTREAM_HEADER + len(pkt.payload)
        if pkt.dest64 is not None:
            n += ADDR64_EXTRA
        if pkt.src16 == NO_16BIT:
            n += ADDR64_EXTRA
        return n * 8 * NS_PER_S // self.params.air_rate_bps

    def _schedule(self, sender: XBeeModule, pkt: RfPacket) -> None:
        p = self.params
        self.counters["packets"] += 1
        receivers = [m for m in self.modules if m is not sender and m.accepts(pkt)]
        air_ns = self.air_time_ns(pkt)
        t = max(pkt.t_ns + int(p.latency_s * NS_PER_S), self._channel_free_ns)
        max_attempts = 1 + (p.mac_retries * (sender.regs.num("RR") + 1) if pkt.ack else 0)
        delivered = False
        attempts = 0
        while attempts < max_attempts:
            attempts += 1
            self.counters["attempts"] += 1
            lost = self._in_dropout(t) or (self._loss_probability > 0 and self.rng.random() < self._loss_probability)
            end = t + air_ns
            if not lost and (receivers or not pkt.ack):
                for rx in receivers:
                    rssi = p.rssi_dbm + (float(self.rng.normal(0.0, p.rssi_noise_db)) if p.rssi_noise_db else 0.0)
                    self._push(end, "deliver", (rx, pkt, float(rssi)))
                    self._events.append(RfDelivered(end, sender.name, rx.name, len(pkt.payload), attempts))
                delivered = bool(receivers)
                if pkt.ack:
                    end += ACK_NS
                t = end
                break
            if not pkt.ack:
                t = end
                break
            t = end + ACK_WAIT_NS + int(self.rng.integers(0, 8)) * BACKOFF_UNIT_NS
        self._channel_free_ns = t
        if delivered:
            self.counters["delivered"] += 1
        else:
            self.counters["failed"] += 1
            self._events.append(RfFailed(t, sender.name, len(pkt.payload), "no_ack" if pkt.ack else "lost"))
        status = TxStatus.SUCCESS if (delivered or not pkt.ack) else TxStatus.NO_ACK
        self._push(t, "done", (sender, pkt.tag, status))
