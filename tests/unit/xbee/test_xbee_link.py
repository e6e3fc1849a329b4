"""Radio link: air time and latency, losses with MAC retries, dropouts, determinism."""

from __future__ import annotations

import numpy as np

from emulators.xbee import (
    ApiParser,
    LinkParams,
    RadioLink,
    RfDelivered,
    RfFailed,
    TxOption,
    XBeeModule,
    XBeeParams,
    encode_frame,
    tx16,
)

MS = 1_000_000
S = 1_000_000_000


def pair(lp: LinkParams, seed: int = 3, gp: XBeeParams | None = None) -> tuple[XBeeModule, XBeeModule, RadioLink]:
    v = XBeeModule(XBeeParams(), np.random.default_rng(1), "telemetry")
    g = XBeeModule(gp or XBeeParams(my=0, dl=1), np.random.default_rng(2), "ground")
    link = RadioLink(lp, np.random.default_rng(seed))
    link.attach(v)
    link.attach(g)
    return v, g, link


def test_delivery_time_is_latency_plus_air_time() -> None:
    v, g, link = pair(LinkParams(latency_s=0.002))
    v.receive(encode_frame(tx16(1, 0, bytes(50))), 100 * MS)
    link.advance(100 * MS)
    (ev,) = link.take_events()
    # (6 PHY + 11 MAC + 2 header + 50) bytes at 250 kbit/s = 2.208 ms, after 2 ms latency.
    assert isinstance(ev, RfDelivered) and ev.t_ns == 100 * MS + 2 * MS + 2_208_000
    link.advance(ev.t_ns - 1)
    assert g.take_output() == b""
    link.advance(ev.t_ns)
    assert len(ApiParser().feed(g.take_output())) == 1


def test_packets_share_the_channel() -> None:
    v, g, link = pair(LinkParams(latency_s=0.0))
    for i in range(3):
        v.receive(encode_frame(tx16(i + 1, 0, bytes(100))), 0)
    link.advance(1 * S)
    times = [e.t_ns for e in link.take_events()]
    air = (6 + 11 + 2 + 100) * 8 * S // 250_000
    ack = 352_000 + 192_000
    assert times == [air, 2 * air + ack, 3 * air + 2 * ack]


def test_50hz_telemetry_with_loss_and_retries() -> None:
    v, g, link = pair(LinkParams(loss_probability=0.3), seed=11)
    statuses: list[int] = []
    received = 0
    for k in range(200):
        t = k * 20 * MS
        v.receive(encode_frame(tx16(1 + k % 255, 0, bytes([k % 256]) * 40)), t)
        link.advance(t)
        statuses += [f[2] for f in ApiParser().feed(v.take_output())]
        received += len(ApiParser().feed(g.take_output()))
    link.advance(5 * S)
    statuses += [f[2] for f in ApiParser().feed(v.take_output())]
    received += len(ApiParser().feed(g.take_output()))
    # 4 attempts per packet: P(all lost) = 0.3^4 ~ 0.8 %.
    assert len(statuses) == 200
    assert statuses.count(0) == received and received >= 190
    assert link.counters["attempts"] > 200 * 1.3


def test_no_ack_packets_get_one_attempt_and_report_success() -> None:
    v, g, link = pair(LinkParams(loss_probability=1.0))
    v.receive(encode_frame(tx16(5, 0, b"x", options=TxOption.DISABLE_ACK)), 0)
    link.advance(1 * S)
    assert ApiParser().feed(v.take_output()) == [bytes([0x89, 5, 0])]
    assert g.take_output() == b"" and link.counters["attempts"] == 1
    assert isinstance(link.take_events()[0], RfFailed)


def test_dropout_window() -> None:
    v, g, link = pair(LinkParams(dropouts=((1.0, 0.5),)))
    got = []
    for k in range(100):
        t = k * 20 * MS
        v.receive(encode_frame(tx16(1, 0, bytes([k]))), t)
        link.advance(t)
        got += [f[5] for f in ApiParser().feed(g.take_output())]
    link.advance(2 * S + 100 * MS)
    got += [f[5] for f in ApiParser().feed(g.take_output())]
    assert [k for k in range(100) if k not in got] == list(range(50, 75))
    link.inject_dropout(3 * S, 1 * S)
    v.receive(encode_frame(tx16(1, 0, b"z")), 3 * S)
    link.advance(4 * S)
    assert g.take_output() == b""


def test_channel_and_pan_must_match() -> None:
    for gp in (XBeeParams(my=0, ch=0x0D), XBeeParams(my=0, pan_id=0x1234)):
        v, g, link = pair(LinkParams(), gp=gp)
        v.receive(encode_frame(tx16(1, 0, b"x")), 0)
        link.advance(1 * S)
        assert g.take_output() == b"" and ApiParser().feed(v.take_output()) == [bytes([0x89, 1, 1])]


def test_seeded_determinism() -> None:
    def run(seed: int) -> list[object]:
        v, g, link = pair(LinkParams(loss_probability=0.5, rssi_noise_db=3.0), seed=seed)
        for k in range(50):
            v.receive(encode_frame(tx16(1, 0, bytes([k]))), k * 20 * MS)
            link.advance(k * 20 * MS)
        link.advance(5 * S)
        return [*link.take_events(), g.take_output()]

    assert run(4) == run(4) and run(4) != run(5)
