"""WakeUp/Reset, baud rates (device vs host), line capacity and overruns, fault hooks."""

from __future__ import annotations

import struct

import pydantic
import pytest

from emulators.xsens.codec import Frame, encode_frame
from emulators.xsens.config_msg import Configuration
from emulators.xsens.defs import MID, ErrorCode, ErrorMode
from emulators.xsens.events import BaudChanged, LineOverload, SampleDropped, SampleSent, State, StateChanged
from emulators.xsens.params import Identity, PowerUp, XsensParams
from emulators.xsens.uart import receive_at_wrong_baud
from tests.unit.xsens.host import Host, exact_params

FLIGHT = [(0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400), (0xE020, 0xFFFF)]
MS = 1_000_000


def configure(h: Host, entries: list[tuple[int, int]], t_ns: int = -100 * MS) -> None:
    h.ask(MID.GOTO_CONFIG, t_ns=t_ns)
    h.ask(MID.SET_OUTPUT_CONFIGURATION, b"".join(struct.pack(">HH", x, f) for x, f in entries), t_ns=t_ns)


# -- WakeUp ---------------------------------------------------------------------------------------

def test_wakeup_ack_within_the_window_enters_config() -> None:
    h = Host.make()
    h.dev.power_cycle(0)
    assert h.frames() == [Frame(MID.WAKEUP)] and h.dev.state is State.WAKEUP
    assert h.send(MID.GOTO_CONFIG, t_ns=100 * MS) == []  # only WakeUpAck counts while waking
    assert h.send(MID.WAKEUP_ACK, t_ns=499 * MS) == []  # no reply to WakeUpAck
    assert h.dev.state is State.CONFIG
    assert h.advance(3_000 * MS) == []  # no data in Config
    assert h.dev.counters["ignored_frames"] == 1


@pytest.mark.parametrize("identity,preamble", [
    (Identity.MK4, [MID.CONFIGURATION, MID.EMTS_DATA]),  # mk4 announces itself first
    (Identity.LEGACY, []),
])
def test_without_wakeup_ack_the_device_measures_after_500_ms(identity: Identity, preamble: list[MID]) -> None:
    h = Host.make(exact_params(identity=identity))
    h.dev.power_cycle(1 * MS)
    out = h.advance(520 * MS)
    assert [f.mid for f in out[: 1 + len(preamble)]] == [MID.WAKEUP, *preamble]
    data = out[1 + len(preamble):]
    assert {f.mid for f in data} == {MID.MTDATA2 if identity is Identity.MK4 else MID.MTDATA}
    # grid instants after 501 ms; an mk4 samples once its 1450 preamble bytes are out (15.7 ms)
    first = 510 * MS if identity is Identity.LEGACY else 520 * MS
    assert [e.t_ns for e in h.of_type(SampleSent)] == list(range(first, 521 * MS, 10 * MS))
    assert h.of_type(SampleSent)[0].packet_counter == 0
    if identity is Identity.MK4:
        assert len(out[1].payload) == 118
        h2 = Host.make(exact_params())
        h2.ask(MID.GOTO_CONFIG)
        assert out[1].payload == h2.ask(MID.REQ_CONFIGURATION).payload
    assert h.send(MID.WAKEUP_ACK, t_ns=530 * MS)[-1:] != [Frame(MID.GOTO_CONFIG_ACK)]
    assert h.dev.measuring  # a late WakeUpAck changes nothing


def test_wakeup_delay_ignores_input_while_booting() -> None:
    h = Host.make(exact_params(wakeup_delay_ns=50 * MS, power_up=PowerUp.WAKEUP))
    h.advance(0)
    assert h.send(MID.WAKEUP_ACK, t_ns=10 * MS) == [] and h.dev.state is State.WAKEUP
    assert h.advance(50 * MS) == [Frame(MID.WAKEUP)]
    h.send(MID.WAKEUP_ACK, t_ns=60 * MS)
    assert h.dev.state is State.CONFIG


# -- Reset and SetBaudrate ------------------------------------------------------------------------

def test_reset_acks_then_wakes_up_again() -> None:
    h = Host.make()
    h.ask(MID.GOTO_CONFIG)
    assert h.send(MID.RESET, t_ns=-10 * MS) == [Frame(MID.RESET_ACK), Frame(MID.WAKEUP)]
    h.send(MID.WAKEUP_ACK, t_ns=-5 * MS)
    assert h.dev.state is State.CONFIG


def test_set_baudrate_takes_effect_after_reset_only() -> None:
    h = Host.make()
    h.dev.line_settings_changed(921_600, -20 * MS)
    h.ask(MID.GOTO_CONFIG, t_ns=-20 * MS)
    assert h.ask(MID.SET_BAUDRATE, b"\x00", t_ns=-20 * MS) == Frame(MID.SET_BAUDRATE_ACK)  # 460800
    assert h.dev.baud_bps == 921_600
    assert h.ask(MID.SET_BAUDRATE, t_ns=-20 * MS) == Frame(MID.SET_BAUDRATE_ACK, b"\x00")
    h.dev.receive(encode_frame(MID.RESET), -10 * MS)
    raw = h.dev.take_output()
    ack = encode_frame(MID.RESET_ACK)
    assert raw.startswith(ack)  # the ack still goes out at the old rate
    assert raw[len(ack):] != encode_frame(MID.WAKEUP)  # WakeUp at 460800 is garbage at 921600
    assert h.dev.baud_bps == 460_800
    assert [e for e in h.dev.take_events() if isinstance(e, BaudChanged)] == [BaudChanged(-10 * MS, 460_800)]
    # the client reopens at the new rate and answers in time (ethz ChangeBaudrate)
    h.dev.line_settings_changed(460_800, -9 * MS)
    h.dev.receive(encode_frame(MID.WAKEUP_ACK), -8 * MS)
    assert h.dev.state is State.CONFIG
    assert h.ask(MID.SET_BAUDRATE, t_ns=-7 * MS) == Frame(MID.SET_BAUDRATE_ACK, b"\x00")


# -- host at the wrong rate -----------------------------------------------------------------------

def test_output_at_the_wrong_host_rate_is_garbled_deterministically() -> None:
    clean = Host.make()
    wrong = [Host.make(), Host.make()]
    for h in wrong:
        h.dev.line_settings_changed(115_200, -1)
    clean.dev.advance(50 * MS)
    out_clean = clean.dev.take_output()
    out = []
    for h in wrong:
        h.dev.advance(50 * MS)
        out.append(h.dev.take_output())
    assert out[0] == out[1]  # deterministic
    assert out[0] != out_clean and 0 < len(out[0]) < len(out_clean)  # host slower: fewer characters
    assert wrong[0].dev.counters["tx_garbled_bytes"] == len(out_clean)
    slow_dev = Host.make(exact_params(baud_bps=9_600))
    slow_dev.dev.line_settings_changed(115_200, -1)
    slow_dev.dev.advance(0)
    assert len(slow_dev.dev.take_output()) > 43  # host faster: more characters


def test_input_at_the_wrong_rate_is_lost_and_counted() -> None:
    h = Host.make()
    h.dev.line_settings_changed(115_200, -2 * MS)
    h.dev.receive(encode_frame(MID.GOTO_CONFIG), -MS)
    assert h.dev.state is State.MEASUREMENT
    assert h.dev.counters["rx_wrong_baud_bytes"] == 5
    h.dev.line_settings_changed(921_600, 0)
    h.dev.receive(encode_frame(MID.GOTO_CONFIG), MS)
    assert h.dev.state is State.CONFIG


def test_uart_model_hand_computed_cases() -> None:
    # 0x00 sent twice as fast as the receiver samples: start and low data bits are seen,
    # data bits 3.. fall on the stop bit and idle line -> 0xF8, stop bit high.
    assert receive_at_wrong_baud(b"\x00", 230_400, 115_200) == b"\xf8"
    # 0xFF at double speed: the start bit is too short to be sampled low -> nothing.
    assert receive_at_wrong_baud(b"\xff", 230_400, 115_200) == b""
    # At half speed the receiver finishes a character inside our data bits and a low stop
    # sample is a framing error (delivered as 0x00 by Linux).
    assert receive_at_wrong_baud(b"\x00", 57_600, 115_200) == b"\x00"
    assert receive_at_wrong_baud(b"\x55\xaa", 115_200, 115_200) == b"\x55\xaa"


# -- line capacity and overruns --------------------------------------------------------------------

def _one_second(error_mode: int, baud: int = 115_200) -> Host:
    h = Host.make(exact_params(baud_bps=baud))
    configure(h, FLIGHT)
    h.ask(MID.SET_ERROR_MODE, struct.pack(">H", error_mode), t_ns=-100 * MS)
    h.ask(MID.GOTO_MEASUREMENT, t_ns=-100 * MS)
    h.sent_frames = h.advance(997_500_000)  # type: ignore[attr-defined]
    return h


def test_configuration_over_line_capacity_is_reported() -> None:
    h = _one_second(ErrorMode.INCREASE_COUNTER)
    assert h.of_type(LineOverload) == [LineOverload(-100 * MS, 69 * 400, 11_520, 115_200)]
    assert h.dev.counters["line_overload"] == 1
    sent, dropped = h.of_type(SampleSent), h.of_type(SampleDropped)
    assert len(sent) + len(dropped) == 400
    # the line carries 11520 B/s: about 167 frames of 69 B, plus what the buffer absorbed
    assert 160 <= len(sent) <= (11_520 + 1024) // 69 + 1
    assert h.dev.counters["overruns"] == len(dropped)


def test_error_mode_1_skips_counter_values_without_errors() -> None:
    h = _one_second(ErrorMode.INCREASE_COUNTER)
    counters = [e.packet_counter or 0 for e in h.of_type(SampleSent)]
    assert counters == sorted(counters) and counters[-1] <= 399 and len(counters) < 400
    assert set(counters) < set(range(400))
    assert h.dev.counters["errors_sent"] == 0


def test_error_mode_0_keeps_the_counter_contiguous() -> None:
    h = _one_second(ErrorMode.IGNORE)
    counters = [e.packet_counter for e in h.of_type(SampleSent)]
    assert counters == list(range(len(counters)))


def test_error_mode_2_sends_error_0x29() -> None:
    h = _one_second(ErrorMode.INCREASE_COUNTER_SEND_ERROR)
    frames = h.sent_frames  # type: ignore[attr-defined]
    errors = [f for f in frames if f == Frame(MID.ERROR, bytes((ErrorCode.DATA_OVERFLOW,)))]
    assert len(errors) == len(h.of_type(SampleDropped)) == h.dev.counters["errors_sent"] > 0
    counters = [e.packet_counter or 0 for e in h.of_type(SampleSent)]
    assert len(counters) + len(errors) == 400 and counters[-1] <= 399


def test_error_mode_3_sends_error_and_goes_to_config() -> None:
    h = Host.make(exact_params(baud_bps=115_200))
    configure(h, FLIGHT)
    h.ask(MID.SET_ERROR_MODE, b"\x00\x03", t_ns=-100 * MS)
    h.ask(MID.GOTO_MEASUREMENT, t_ns=-100 * MS)
    frames = h.advance(997_500_000)
    assert frames[-1] == Frame(MID.ERROR, bytes((ErrorCode.DATA_OVERFLOW,)))
    assert h.dev.state is State.CONFIG and len(h.of_type(SampleDropped)) == 1
    assert StateChanged(h.of_type(SampleDropped)[0].t_ns, State.MEASUREMENT, State.CONFIG) in h.events


def test_fast_enough_line_has_no_overruns() -> None:
    h = _one_second(ErrorMode.INCREASE_COUNTER, baud=460_800)
    assert h.of_type(LineOverload) == [] and len(h.of_type(SampleSent)) == 400


# -- fault hooks ----------------------------------------------------------------------------------

def test_silence_stops_streaming_and_the_counter_keeps_running() -> None:
    h = Host.make()
    configure(h, FLIGHT)
    h.ask(MID.GOTO_MEASUREMENT, t_ns=-100 * MS)
    h.advance(0)
    h.dev.set_silenced(True)
    assert h.advance(100 * MS) == []
    assert h.dev.output_period_ns == 2_500_000  # still due: the bench keeps waiting on it
    h.dev.set_silenced(False)
    h.advance(102_500_000)
    assert [e.packet_counter for e in h.of_type(SampleSent)] == [0, 41]
    assert h.dev.counters["silenced_samples"] == 40


def test_power_cycle_resets_counter_and_state() -> None:
    h = Host.make()
    h.advance(100 * MS)
    h.dev.power_cycle(105 * MS)
    assert h.dev.state is State.WAKEUP and h.dev.output_period_ns is None
    h.send(MID.WAKEUP_ACK, t_ns=110 * MS)
    h.ask(MID.GOTO_MEASUREMENT, t_ns=111 * MS)
    h.advance(120 * MS)
    assert h.of_type(SampleSent)[-1].packet_counter == 0


# -- params ---------------------------------------------------------------------------------------

def test_params_validate_from_a_rig_table() -> None:
    table = {"identity": "legacy", "baud_bps": 460_800, "power_on_offset_ns": 123,
             "output_configuration": [[0x1020, 0xFFFF], [0x2034, 400]], "gyro_noise_radps_per_rthz": 0.0}
    p = pydantic.TypeAdapter(XsensParams).validate_python(table)
    assert p.identity is Identity.LEGACY and p.output_configuration == ((0x1020, 0xFFFF), (0x2034, 400))
    with pytest.raises(pydantic.ValidationError, match="not_a_key"):
        pydantic.TypeAdapter(XsensParams).validate_python({"not_a_key": 1})
    with pytest.raises(ValueError):
        XsensParams(baud_bps=123_456)


def test_params_select_the_mk4_factory_configuration() -> None:
    p = exact_params(output_configuration=((0x2034, 400), (0x1020, 0xFFFF)), identity=Identity.MK4)
    h = Host.make(p)
    assert h.dev.output_period_ns == 2_500_000
    h.ask(MID.GOTO_CONFIG)
    cfg = Configuration.unpack(h.ask(MID.REQ_CONFIGURATION).payload)
    assert cfg.output_mode == 0 and cfg.mtdata_length == 0
