"""The Bus Pirate driver against the real emulator when replies come late, in pieces or with
garbage (the loaded bench): entry drains and checks exactly, a late reply costs one sample
and is never read as data, a bad one is put right by a non-blocking re-entry."""

from __future__ import annotations

import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from emulators.buspirate import Mode
from flightcode.drivers.base import DeviceError
from flightcode.drivers.buspirate_spi import BusPirateSpi, LinkState
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.log import Logger
from tests.unit.flightcode.emulated_buspirate import (
    TICK_NS,
    Delivery,
    EmulatedBusPiratePort,
    FakeClock,
    expected_codes,
    prompt,
)

READ_TIMEOUT_S = 0.02
TICK_WALL_S = 0.0005  # lockstep on the bench: a sample every ~0.5 ms of wall time
SETUP = [bytes(20), b"\x00", b"\x01", b"\x8a", b"\x63", b"\x49", b"\x03"]
WIRE = bytes.fromhex("02 13 60 00 00 00 03 02 13 64 00 00 00 03 02 13 68 00 00 00 03 02 13 6c 00 00 00 03")


def make(delivery: Delivery = prompt, *, attempts: int = 3, mode: Mode | None = None,
         ) -> tuple[Mcp3204Reader, BusPirateSpi, EmulatedBusPiratePort, FakeClock, io.StringIO]:
    clock = FakeClock()
    port = EmulatedBusPiratePort(clock, timeout_s=READ_TIMEOUT_S, delivery=delivery)
    if mode is not None:  # put the emulator where a previous run left it
        port.device.receive(bytes(20) + (b"\x01" if mode is Mode.SPI else b""), 0)
        port.device.take_output()
    out = io.StringIO()
    bridge = BusPirateSpi(port, speed_hz=1_000_000, entry_attempts=attempts, reply_timeout_s=0.2, quiet_s=0.03,
                          resync_interval_ns=250_000_000, log=Logger(out), clock=clock)
    return Mcp3204Reader(bridge, (0, 1, 2, 3)), bridge, port, clock, out


def run(reader: Mcp3204Reader, port: EmulatedBusPiratePort, clock: FakeClock, k0: int, n: int,
        ) -> list[tuple[int, ...] | None]:
    """Samples k0..k0+n-1; every code that comes back must be this sample's."""
    got = []
    for k in range(k0, k0 + n):
        port.t_ns = k * TICK_NS
        codes = reader.read_codes(port.t_ns)
        assert codes is None or codes == expected_codes(port.t_ns), f"sample {k} misread {codes}"
        got.append(codes)
        clock.advance(TICK_WALL_S)
    return got


# -- entry ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", [None, Mode.BBIO, Mode.SPI])
def test_entry_from_any_mode_one_command_at_a_time(mode: Mode | None) -> None:
    reader, bridge, port, clock, out = make(mode=mode)
    bridge.enter_spi()
    assert port.device.mode is Mode.SPI and bridge.in_sync
    assert port.writes == SETUP  # flashrom's order: zeros, 00, 01, then each setup command alone
    # in BBIO or SPI mode each zero is answered by a BBIO1, all drained before the single 00
    assert f"drained={5 * (1 if mode is None else 20)}" in out.getvalue()
    assert run(reader, port, clock, 0, 3) == [expected_codes(k * TICK_NS) for k in range(3)]


def test_entry_waits_for_a_slow_stream_of_bbio1_to_end() -> None:
    # Bridge left in SPI mode; its 20 BBIO1 trickle in 5 bytes every 10 ms (an FT232 with a
    # 10 ms latency timer): the stream ends 100 ms after the zeros, longer than quiet_s.
    def trickle(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        if i == 0:
            return [(now + 0.01 * (j + 1), data[5 * j : 5 * j + 5]) for j in range(len(data) // 5)]
        return prompt(i, data, now)

    _, bridge, _, _, out = make(trickle, mode=Mode.SPI)
    bridge.enter_spi()
    assert bridge.in_sync and "attempts=1" in out.getvalue() and "drained=100" in out.getvalue()


def test_a_late_bbio1_arriving_after_the_flush_fails_the_attempt_not_the_boot() -> None:
    # The answers to the zeros are held up for 41 ms: the line has been quiet for quiet_s when
    # the driver flushes and sends the single 00 (at 40 ms, after two 20 ms read timeouts), so
    # they land in front of the answer to it (2 ms) and must not be taken for it.
    def held(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [(now + {0: 0.041, 1: 0.002}.get(i, 50e-6), data)]

    _, bridge, port, _, out = make(held, mode=Mode.SPI)
    bridge.enter_spi()
    text = out.getvalue()
    assert "event=adc.entry_retry attempt=1 reason=\"00 answered 42 42 49 4f 31" in text
    assert "event=adc.spi_mode attempts=2" in text and port.device.mode is Mode.SPI


def test_a_stray_byte_after_a_setup_ack_fails_the_attempt() -> None:
    def stray(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [(now + 50e-6, data + (b"\x00" if i == 3 else b""))]  # a 00 after the ack of 8A

    _, bridge, _, _, out = make(stray)
    bridge.enter_spi()
    assert 'reason="63 answered 00 (expected 01)"' in out.getvalue()
    assert "event=adc.spi_mode attempts=2" in out.getvalue() and bridge.in_sync


def test_dead_bridge_fails_boot_naming_the_adc_after_bounded_waits() -> None:
    _, bridge, _, clock, _ = make(lambda i, d, now: [], attempts=2)
    with pytest.raises(DeviceError) as err:
        bridge.enter_spi()
    assert err.value.device == "adc" and "after 2 attempt(s): no BBIO1 after 00 (got nothing)" in err.value.reason
    # each attempt: quiet_s of drain + reply_timeout_s for the BBIO1, rounded up to read timeouts
    assert clock.now_s <= 2 * (0.03 + 0.2 + 2 * READ_TIMEOUT_S)


# -- late, fragmented and garbled replies in flight ---------------------------------------------------
def late_every(n: int, delay_s: float) -> Delivery:
    def delivery(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [(now + (delay_s if len(data) == 28 and i % n == 0 else 50e-6), data)]

    return delivery


@pytest.mark.parametrize("delay_s", [0.025, 0.06, 0.15])
def test_a_late_reply_costs_one_sample_and_no_resync(delay_s: float) -> None:
    reader, bridge, port, clock, _ = make(late_every(10, delay_s))
    bridge.enter_spi()
    run(reader, port, clock, 0, 1000)
    late = bridge.counters["late_replies"]
    assert late >= 3 and bridge.counters["late_replies_discarded"] in (late, late - 1)
    assert bridge.counters["resyncs"] == 0 and bridge.counters["bad_ack"] == 0
    # the late transfer's sample has no data; so have the samples during which its bytes are
    # still owed (no write goes out meanwhile): none if it lands within the next sample
    assert reader.counters["failed_reads"] == late
    owed_samples = max(0, int((delay_s - READ_TIMEOUT_S) / TICK_WALL_S))
    assert reader.counters["no_transfer"] <= late * owed_samples
    assert reader.counters["reads"] + late + reader.counters["no_transfer"] == 1000


def test_reply_in_single_byte_fragments_reads_every_sample() -> None:
    def bytewise(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [(now + 1e-4 * (j + 1), data[j : j + 1]) for j in range(len(data))]

    reader, bridge, port, clock, _ = make(bytewise)
    bridge.enter_spi()
    assert None not in run(reader, port, clock, 0, 50)
    assert bridge.counters["late_replies"] == 0


def test_reply_straddling_the_timeout_is_completed_next_sample() -> None:
    def straddle(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        if len(data) == 28 and i == 10:
            return [(now + 1e-4, data[:9]), (now + 0.0202, data[9:])]  # just after the timeout
        return prompt(i, data, now)

    reader, bridge, port, clock, _ = make(straddle)
    bridge.enter_spi()
    got = run(reader, port, clock, 0, 10)
    assert got.count(None) == 1 and got[10 - len(SETUP)] is None  # write 10 is the 4th transfer
    assert bridge.counters["late_replies_discarded"] == 1 and bridge.counters["resyncs"] == 0


def test_garbage_between_samples_is_flushed_before_the_write() -> None:
    reader, bridge, port, clock, _ = make()
    bridge.enter_spi()
    run(reader, port, clock, 0, 5)
    port.inject(b"\x01\x01\x55\x0a\x0b\x01")  # looks like a channel's reply
    assert None not in run(reader, port, clock, 5, 5)
    assert bridge.counters["unexpected_input"] == 1 and bridge.counters["resyncs"] == 0


def test_garbage_inside_a_reply_resyncs_without_stalling_and_recovers() -> None:
    def noisy(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        if len(data) == 28 and i == 12:
            return [(now + 1e-4, data[:7] + b"\xee" + data[7:])]
        return prompt(i, data, now)

    reader, bridge, port, clock, out = make(noisy)
    bridge.enter_spi()
    t0 = clock.now_s
    got = run(reader, port, clock, 0, 600)
    assert bridge.counters["bad_ack"] == 1 and bridge.counters["resyncs"] == 1
    assert "event=adc.resynced" in out.getvalue()
    assert got[-1] is not None
    # the re-entry waited reply_timeout_s for the garbled reply's rest, then drained quiet_s
    first_back = next(k for k in range(7, 600) if got[k] is not None)
    assert first_back * TICK_WALL_S >= 0.2 + 0.03
    # the wait and the re-entry are spread over samples: no call blocked longer than a read timeout
    assert clock.now_s - t0 <= 600 * TICK_WALL_S + 2 * READ_TIMEOUT_S


def test_a_garbled_reply_whose_rest_comes_late_is_not_read_after_the_resync() -> None:
    # Found by LoadedBench: a noise byte lands in front of a reply that is itself 100 ms late.
    # The garbled reply starts a re-entry; the real reply then arrives after it, in the middle
    # of a later transfer, and has the shape of a good one. The re-entry must wait it out.
    def late(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [(now + (0.1 if i == len(SETUP) else 50e-6), data)]  # the first transfer

    reader, bridge, port, clock, _ = make(late)
    bridge.enter_spi()
    port.inject(b"\x00", after_s=0.001)
    got = run(reader, port, clock, 0, 800)  # asserts that no sample is misread
    assert bridge.counters["bad_ack"] == 1 and bridge.counters["samples_waiting_stale"] > 100
    assert got[-1] is not None and bridge.counters["resyncs"] == 1


def test_a_lost_reply_is_given_up_after_reply_timeout_and_the_bridge_reentered() -> None:
    lost = {"on": False}

    def maybe(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        return [] if lost["on"] else prompt(i, data, now)

    reader, bridge, port, clock, _ = make(maybe)
    bridge.enter_spi()
    lost["on"] = True
    # given up 0.2 s after the timed-out read; the re-entry then waits 0.03 s for quiet and
    # 0.2 s for a BBIO1: 0.6 s of samples see one failed re-entry
    run(reader, port, clock, 0, 1200)
    assert bridge.counters["replies_lost"] == 1 and bridge.counters["resync_failures"] >= 1
    assert bridge.counters["requests"] == 1  # nothing else was written while the reply was owed
    lost["on"] = False
    got = run(reader, port, clock, 1200, 1200)
    assert got[-1] is not None and bridge.in_sync
    # back within one unanswered attempt (0.2 s), the resync interval and the quiet time
    first = next(i for i, c in enumerate(got) if c is not None)
    assert first * TICK_WALL_S <= 0.2 + 0.03 + 250 * TICK_WALL_S / 2.5 + 0.01


@pytest.mark.parametrize("taken", [0, 1, 10, 23])
def test_a_short_write_costs_its_sample_and_the_bridge_is_reentered(taken: int) -> None:
    # The port is non-blocking (write_timeout=0): a full output buffer takes part of the
    # request. The bridge then holds a torn transfer; nothing it answers may be read as data.
    reader, bridge, port, clock, _ = make()
    bridge.enter_spi()
    assert None not in run(reader, port, clock, 0, 5)
    port.short_next = taken
    got = run(reader, port, clock, 5, 1200)  # asserts that no sample is misread
    assert got[0] is None
    assert bridge.counters["short_writes"] == 1 and bridge.counters["sync_lost_short_write"] == 1
    assert bridge.counters["resyncs"] == 1 and bridge.in_sync and got[-1] is not None


# -- any schedule: never a misread, always recovers -----------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(delays=st.lists(st.sampled_from([50e-6, 0.004, 0.019, 0.021, 0.05, 0.12, 0.19]), min_size=1, max_size=30),
       splits=st.lists(st.integers(1, 23), max_size=30), garbage=st.lists(st.binary(max_size=4), max_size=30))
def test_any_delivery_schedule_never_misreads_and_recovers(delays: list[float], splits: list[int],
                                                           garbage: list[bytes]) -> None:
    def chaos(i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        if now >= 0.5:  # the disturbance ends after half a second of wall time
            return prompt(i, data, now)
        d = delays[i % len(delays)]
        cut = splits[i % len(splits)] % len(data) if splits else 0
        junk = garbage[i % len(garbage)] if garbage else b""
        return [(now + d, data[:cut] + junk), (now + d + 0.001, data[cut:])]

    reader, bridge, port, clock, _ = make(chaos, attempts=10)
    try:
        bridge.enter_spi()
    except DeviceError:
        return  # 10 garbled entries in a row: the boot refuses, which is also right
    run(reader, port, clock, 0, 400)
    k = 400
    while k < 4000 and run(reader, port, clock, k, 400)[-1] is None:  # a bounded time to recover
        k += 400
    assert bridge.in_sync and None not in run(reader, port, clock, k + 400, 3)


class LoadedBench(RuleBasedStateMachine):
    """Samples interleaved with the bench's bad moments; the invariant is the driver's promise."""

    def __init__(self) -> None:
        super().__init__()
        self.next_delay = 50e-6
        self.reader, self.bridge, self.port, self.clock, _ = make(self._deliver)
        self.bridge.enter_spi()
        self.k = 0

    def _deliver(self, i: int, data: bytes, now: float) -> list[tuple[float, bytes]]:
        delay, self.next_delay = self.next_delay, 50e-6
        return [(now + delay, data)]

    @rule()
    def sample(self) -> None:
        run(self.reader, self.port, self.clock, self.k, 1)
        self.k += 1

    @rule(delay_s=st.sampled_from([0.021, 0.04, 0.1, 0.19]))  # within reply_timeout_s: late, not lost
    def next_reply_late(self, delay_s: float) -> None:
        self.next_delay = delay_s

    @rule(junk=st.binary(min_size=1, max_size=8), after_s=st.sampled_from([0.0, 0.001, 0.02]))
    def line_noise(self, junk: bytes, after_s: float) -> None:
        self.port.inject(junk, after_s)

    @rule(dt_s=st.sampled_from([0.001, 0.05, 0.3]))
    def bench_stalls(self, dt_s: float) -> None:
        self.clock.advance(dt_s)

    @precondition(lambda self: self.k > 0)
    @invariant()
    def link_state_is_consistent(self) -> None:
        b = self.bridge
        assert b.state in LinkState
        assert (b.state is LinkState.READY) == b.in_sync

    def teardown(self) -> None:
        for _ in range(10):  # once the bench behaves, the data come back
            if run(self.reader, self.port, self.clock, self.k, 400)[-1] is not None:
                return
            self.k += 400
        raise AssertionError(f"no recovery: {self.bridge.state} {dict(self.bridge.counters)}")


LoadedBench.TestCase.settings = settings(max_examples=30, stateful_step_count=30, deadline=None)
TestLoadedBench = LoadedBench.TestCase
