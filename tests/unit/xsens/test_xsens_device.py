"""MtiDevice state machine and requests, driven sans-I/O (golden sources in the JSON vectors)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from emulators.xsens.codec import Frame, encode_frame
from emulators.xsens.config_msg import Configuration
from emulators.xsens.defs import MID, ErrorCode, LegacyMode
from emulators.xsens.events import CommandHandled, SampleSent, State, StateChanged
from emulators.xsens.params import Identity, PowerUp
from tests.unit.xsens.host import Host, exact_params
from tests.unit.xsens.vectors import frame, hexb, vectors

ERR_04 = Frame(MID.ERROR, b"\x04")
BOOT = -1_000_000_000  # configuration happens at negative sim time


def mk4() -> Host:
    return Host.make(exact_params())


def legacy_host() -> Host:
    return Host.make(exact_params(identity=Identity.LEGACY))


# -- power-up ---------------------------------------------------------------------------------

@pytest.mark.parametrize("identity,mid", [(Identity.MK4, MID.MTDATA2), (Identity.LEGACY, MID.MTDATA)])
def test_constructor_leaves_the_device_measuring_without_wakeup(identity: Identity, mid: MID) -> None:
    h = Host.make(exact_params(identity=identity))
    assert h.dev.state is State.MEASUREMENT and h.dev.measuring
    assert h.dev.output_period_ns == 10_000_000  # factory default: 100 Hz
    assert h.advance(-5_000_000) == []  # boot time never produces data
    out = h.advance(20_000_000)
    assert [f.mid for f in out] == [mid] * 3  # t = 0, 10 ms, 20 ms


def test_wakeup_power_up_is_opt_in() -> None:
    h = Host.make(exact_params(power_up=PowerUp.WAKEUP))
    assert h.advance(BOOT) == [Frame(MID.WAKEUP)]
    assert h.dev.state is State.WAKEUP


# -- GoToConfig / GoToMeasurement ---------------------------------------------------------------

def test_goto_config_is_acked_with_the_documented_frame_and_stops_data() -> None:
    h = mk4()
    h.dev.receive(hexb(frame("GoToConfig")["hex"]), 15_000_000)
    out = h.raw()
    # the sample at 10 ms was due before the command arrived at 15 ms
    assert out.endswith(hexb(frame("GoToConfigAck")["hex"]))
    assert h.dev.state is State.CONFIG and h.dev.output_period_ns is None
    assert h.advance(2_000_000_000) == []
    assert StateChanged(15_000_000, State.MEASUREMENT, State.CONFIG) in h.events
    # GoToConfig in Config just confirms
    assert h.ask(MID.GOTO_CONFIG, t_ns=2_000_000_000) == Frame(MID.GOTO_CONFIG_ACK)


def test_goto_measurement_streams_from_the_next_grid_instant() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.GOTO_MEASUREMENT, t_ns=3_000_000) == Frame(MID.GOTO_MEASUREMENT_ACK)
    h.advance(25_000_000)
    assert [e.t_ns for e in h.of_type(SampleSent)] == [10_000_000, 20_000_000]


def test_measurement_started_at_boot_gives_the_first_sample_at_t0() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG, t_ns=BOOT)
    h.ask(MID.GOTO_MEASUREMENT, t_ns=BOOT // 2)
    h.advance(0)
    assert [(e.t_ns, e.packet_counter, e.sample_time_fine) for e in h.of_type(SampleSent)] == [(0, 0, 0)]


# -- identity requests (mk4 = the golden MTi-300) -------------------------------------------------

def test_mk4_identity_replies() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.REQ_DID) == Frame(MID.DEVICE_ID, hexb("03 70 03 F8"))
    assert h.ask(MID.REQ_PRODUCT_CODE) == Frame(MID.PRODUCT_CODE, b"MTi-300-2A5G4       ")
    assert h.ask(MID.REQ_HARDWARE_VERSION) == Frame(MID.HARDWARE_VERSION, b"\x02\x00")
    assert encode_frame(*_mp(h.ask(MID.REQ_FW_REV))) == hexb(frame("FirmwareRev 1.8.2 b37 r70964")["hex"])
    assert h.ask(MID.SET_BAUDRATE) == Frame(MID.SET_BAUDRATE_ACK, b"\x80")  # 921600 (legacy code, as devices answer)
    assert h.ask(MID.RUN_SELFTEST) == Frame(MID.SELFTEST_RESULTS, b"\x01\xff")


def _mp(f: Frame) -> tuple[int, bytes]:
    return f.mid, f.payload


def test_legacy_identity_replies() -> None:
    h = legacy_host()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.REQ_DID) == Frame(MID.DEVICE_ID, hexb("00 50 0A 2B"))
    fw = h.ask(MID.REQ_FW_REV)
    assert fw.mid == MID.FIRMWARE_REV and len(fw.payload) == 3
    assert h.ask(MID.REQ_DATA_LENGTH) == Frame(MID.DATA_LENGTH, b"\x00\x12")  # quaternion + counter
    cfg = Configuration.unpack(h.ask(MID.REQ_CONFIGURATION).payload)
    assert (cfg.output_mode, cfg.output_settings, cfg.mtdata_length, cfg.sample_period) == (4, 1, 18, 1152)


@pytest.mark.parametrize("mid,payload", [
    (MID.SET_OUTPUT_CONFIGURATION, b""), (MID.SET_OPTION_FLAGS, b""), (MID.SET_STRING_OUTPUT_TYPE, b"\x00\x00"),
    (MID.REQ_AVAILABLE_FILTER_PROFILES, b""), (MID.REQ_EMTS, b"\x00\xff"), (MID.SET_SYNC_SETTINGS, b""),
    (MID.SET_ALIGNMENT_ROTATION, b"\x00"), (MID.SET_FILTER_PROFILE, b""),
])
def test_legacy_answers_mk4_only_messages_with_error_04(mid: MID, payload: bytes) -> None:
    h = legacy_host()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(mid, payload) == ERR_04
    assert h.dev.counters["unknown_mids"] == 1


def test_mk4_answers_req_data_length_with_error_04() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.REQ_DATA_LENGTH) == ERR_04


@pytest.mark.parametrize("mid", [0x06, 0x7F, 0xA4, 0xDC, 0x86, 0x60, 0xFE])
def test_unknown_or_unsupported_mid_gets_error_04_in_both_states(mid: int) -> None:
    h = mk4()
    assert h.ask(mid) == ERR_04  # measuring
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(mid) == ERR_04
    assert h.dev.counters["unknown_mids"] == 2
    assert h.of_type(CommandHandled)[-1] == CommandHandled(BOOT, mid, MID.ERROR, 0x04)


def test_wrong_payload_length_gets_error_04() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.SET_BAUDRATE, b"\x02\x00") == ERR_04
    assert h.ask(MID.SET_OUTPUT_CONFIGURATION, b"\x10\x20\xff") == ERR_04
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"") == ERR_04


def test_config_only_messages_in_measurement_get_error_04_and_streaming_goes_on() -> None:
    h = mk4()
    for i, mid in enumerate((MID.REQ_DID, MID.REQ_CONFIGURATION, MID.SET_OUTPUT_CONFIGURATION, MID.GOTO_MEASUREMENT)):
        assert h.send(mid, t_ns=i * 1_000_000 + 500_000)[-1] == ERR_04
    assert h.dev.counters["wrong_state"] == 4
    assert h.dev.measuring
    assert len([f for f in h.advance(100_000_000) if f.mid == MID.MTDATA2]) == 10


def test_bad_checksum_is_silently_dropped_and_counted() -> None:
    h = mk4()
    bad = bytearray(encode_frame(MID.GOTO_CONFIG))
    bad[-1] ^= 0xFF
    h.dev.receive(bytes(bad), BOOT)
    assert h.frames() == [] and h.dev.state is State.MEASUREMENT
    assert h.dev.counters["checksum_errors"] == 1


def test_frames_for_another_bus_id_are_ignored() -> None:
    h = mk4()
    h.dev.receive(encode_frame(MID.GOTO_CONFIG, bid=0x02), BOOT)
    assert h.frames() == [] and h.dev.counters["ignored_frames"] == 1
    h.dev.receive(encode_frame(MID.GOTO_CONFIG, bid=0x01), BOOT)  # first device on the bus = us
    assert h.frames() == [Frame(MID.GOTO_CONFIG_ACK)]


# -- the MT Manager capture exchange --------------------------------------------------------------

def test_mt_manager_exchange_replies_match_the_capture() -> None:
    """Host frames and replies from the golden MTi-300 capture (MT Manager configuration)."""
    h = mk4()
    req = {f["name"]: hexb(f["hex"]) for f in vectors()["frames"]}

    def exchange(name: str) -> bytes:
        h.dev.receive(req[name], BOOT)
        return h.raw()

    assert exchange("GoToConfig") == req["GoToConfigAck"]
    assert exchange("SetStringOutputType 0") == req["StringOutputTypeAck"]
    c1 = Frame(*_mp(h.parser.feed(exchange("SetOutputConfiguration (MT Manager, 12 entries)"))[0]))
    # The device applies and lists all twelve (the capture's two-entry reply answers a
    # counters-only request; see test_counters_only_configuration_reply_matches_the_capture).
    assert c1.mid == MID.OUTPUT_CONFIGURATION and c1.payload == hexb(
        frame("SetOutputConfiguration (MT Manager, 12 entries)")["payload"])
    assert exchange("InitMT") == req["InitMTResults"]
    cfg = vectors()["configuration_mti300"]
    assert exchange("ReqConfiguration") == encode_frame(MID.CONFIGURATION, hexb(cfg["payload"]))
    assert exchange("ReqFWRev") == req["FirmwareRev 1.8.2 b37 r70964"]
    profiles = encode_frame(MID.AVAILABLE_FILTER_PROFILES, hexb(vectors()["filter_profiles_mti300"]["payload"]))
    assert profiles[-1] == 0xF1
    assert exchange("ReqAvailableFilterProfiles") == profiles
    emts = exchange("ReqEMTS")
    assert emts[:6] == hexb("FA FF 91 FF 05 28") and len(emts) == 7 + vectors()["emts_length"]
    assert exchange("ReqAvailableFilterProfiles") == profiles
    assert exchange("GoToMeasurement") == req["GoToMeasurementAck"]
    assert h.dev.measuring and h.dev.output_period_ns == 2_500_000


def test_counters_only_configuration_reply_matches_the_capture() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    h.dev.receive(encode_frame(MID.SET_OUTPUT_CONFIGURATION, hexb("10 20 FF FF 10 60 FF FF")), BOOT)
    assert h.raw() == hexb(frame("OutputConfiguration (capture, 2 entries)")["hex"])


# -- output configuration -----------------------------------------------------------------------

def _entries(payload: bytes) -> list[tuple[int, int]]:
    return [struct.unpack(">HH", payload[i : i + 4]) for i in range(0, len(payload), 4)]


def _set_config(h: Host, entries: list[tuple[int, int]]) -> Frame:
    return h.ask(MID.SET_OUTPUT_CONFIGURATION, b"".join(struct.pack(">HH", x, f) for x, f in entries))


def test_flight_code_configuration_is_applied_exactly() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    request = [(0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400), (0xE020, 0xFFFF)]
    assert _entries(_set_config(h, request).payload) == request
    assert _entries(h.ask(MID.SET_OUTPUT_CONFIGURATION).payload) == request  # Req returns the stored list


@pytest.mark.parametrize("requested,applied", [
    ((0x2030, 300), (0x2030, 200)),  # not a divisor of the 400 Hz grid
    ((0x2030, 1000), (0x2030, 400)),  # above the orientation maximum
    ((0x4020, 2000), (0x4020, 400)),  # inertial max is 2000 Hz, the sample grid is 400 Hz
    ((0x4020, 3), (0x4020, 2)),
    ((0xC020, 400), (0xC020, 100)),  # magnetic field max 100 Hz
    ((0x3010, 0xFFFF), (0x3010, 50)),  # 0xFFFF on a data item = its maximum
    ((0x1023, 0xFFFF), (0x1020, 0xFFFF)),  # format bits of an integer item are cleared
])
def test_rates_are_coerced_and_the_reply_lists_what_was_applied(requested: tuple, applied: tuple) -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert _entries(_set_config(h, [requested]).payload) == [applied]


def test_unknown_xdis_are_not_applied() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert _entries(_set_config(h, [(0x5042, 100), (0x2030, 100), (0x203C, 100), (0x0000, 0)]).payload) == [
        (0x2030, 100)]
    assert _set_config(h, [(0x0000, 0)]).payload == b""  # ethz's "clear" entry
    h.ask(MID.GOTO_MEASUREMENT)
    assert h.dev.output_period_ns is None and h.advance(1_000_000_000) == []


def test_more_than_32_entries_is_an_invalid_parameter() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert _set_config(h, [(0x1020, 0xFFFF)] * 33) == Frame(MID.ERROR, bytes((ErrorCode.INVALID_PARAM,)))


# -- stored values are what the answers carry -----------------------------------------------------

@pytest.mark.parametrize("mid,value,reply_len", [
    (MID.SET_ERROR_MODE, b"\x00\x03", 2), (MID.SET_LOCATION_ID, b"\x12\x34", 2),
    (MID.SET_STRING_OUTPUT_TYPE, b"\x00\x00", 2), (MID.SET_FILTER_PROFILE, b"\x00\x2b", 2),
    (MID.SET_BAUDRATE, b"\x00", 1), (MID.SET_PERIOD, b"\x01\x20", 2), (MID.SET_OUTPUT_SKIP_FACTOR, b"\x00\x01", 2),
    (MID.SET_SYNC_SETTINGS, bytes(range(12)), 12),
])
def test_set_then_request_returns_the_stored_value(mid: MID, value: bytes, reply_len: int) -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(mid, value) == Frame(mid + 1)  # set acks carry no data
    assert h.ask(mid) == Frame(mid + 1, value)


def test_option_flags_set_and_clear() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    assert h.ask(MID.SET_OPTION_FLAGS) == Frame(MID.SET_OPTION_FLAGS_ACK, bytes(4))
    h.ask(MID.SET_OPTION_FLAGS, struct.pack(">II", 0x0000_0011, 0))
    h.ask(MID.SET_OPTION_FLAGS, struct.pack(">II", 0x0000_0100, 0x0000_0001))
    assert h.ask(MID.SET_OPTION_FLAGS) == Frame(MID.SET_OPTION_FLAGS_ACK, struct.pack(">I", 0x110))


def test_alignment_rotation_request_has_length_one() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    identity = struct.pack(">4f", 1.0, 0.0, 0.0, 0.0)
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"\x01") == Frame(MID.SET_ALIGNMENT_ROTATION_ACK, b"\x01" + identity)
    q = struct.pack(">4f", 0.0, 0.0, 0.0, 1.0)  # 180 deg about z, local frame
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"\x01" + q) == Frame(MID.SET_ALIGNMENT_ROTATION_ACK)
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"\x01") == Frame(MID.SET_ALIGNMENT_ROTATION_ACK, b"\x01" + q)
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"\x00") == Frame(MID.SET_ALIGNMENT_ROTATION_ACK, b"\x00" + identity)
    assert h.ask(MID.SET_ALIGNMENT_ROTATION, b"\x02") == Frame(MID.ERROR, bytes((ErrorCode.INVALID_PARAM,)))


@pytest.mark.parametrize("mid,payload,code", [
    (MID.SET_BAUDRATE, b"\x0e", ErrorCode.BAUDRATE_INVALID), (MID.SET_BAUDRATE, b"\x7f", ErrorCode.BAUDRATE_INVALID),
    (MID.SET_ERROR_MODE, b"\x00\x04", ErrorCode.INVALID_PARAM),
    (MID.SET_STRING_OUTPUT_TYPE, b"\x00\x01", ErrorCode.INVALID_PARAM),  # NMEA output is not emulated
    (MID.SET_FILTER_PROFILE, b"\x00\x05", ErrorCode.INVALID_FILTER_PROFILE),
    (MID.SET_PERIOD, b"\x00\x64", ErrorCode.INVALID_PERIOD), (MID.SET_PERIOD, b"\x04\x81", ErrorCode.INVALID_PERIOD),
    (MID.SET_PERIOD, b"\x00\xe1", ErrorCode.INVALID_PERIOD),  # 512 Hz: valid on a real MTi, off the 400 Hz grid
    (MID.SET_OUTPUT_MODE, b"\x00\x10", ErrorCode.INVALID_PARAM),  # position: MTi-G only
])
def test_refused_values_keep_the_stored_value(mid: MID, payload: bytes, code: ErrorCode) -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    before = h.ask(mid)
    assert h.ask(mid, payload) == Frame(MID.ERROR, bytes((code,)))
    assert h.ask(mid) == before
    assert h.dev.counters["bad_parameters"] == 1


def test_restore_factory_defaults() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    _set_config(h, [(0x2030, 400)])
    h.ask(MID.SET_LOCATION_ID, b"\x00\x07")
    assert h.ask(MID.RESTORE_FACTORY_DEF) == Frame(MID.RESTORE_FACTORY_DEF_ACK)
    assert _entries(h.ask(MID.SET_OUTPUT_CONFIGURATION).payload) == [
        (0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2010, 100), (0xE020, 0xFFFF)]
    assert h.ask(MID.SET_LOCATION_ID) == Frame(MID.SET_LOCATION_ID_ACK, b"\x00\x00")
    assert h.ask(MID.SET_BAUDRATE) == Frame(MID.SET_BAUDRATE_ACK, b"\x02")  # 115200 after the next reset


# -- legacy output --------------------------------------------------------------------------------

def test_legacy_configuration_fields_match_the_mtdata_actually_sent() -> None:
    h = legacy_host()
    h.ask(MID.GOTO_CONFIG)
    mode, settings_ = LegacyMode.CALIBRATED | LegacyMode.ORIENTATION | LegacyMode.STATUS, 0x8000_0005
    assert h.ask(MID.SET_OUTPUT_MODE, struct.pack(">H", mode)) == Frame(MID.SET_OUTPUT_MODE_ACK)
    assert h.ask(MID.SET_OUTPUT_SETTINGS, struct.pack(">I", settings_)) == Frame(MID.SET_OUTPUT_SETTINGS_ACK)
    assert h.ask(MID.SET_PERIOD, struct.pack(">H", 288)) == Frame(MID.SET_PERIOD_ACK)
    assert h.ask(MID.SET_OUTPUT_MODE) == Frame(MID.SET_OUTPUT_MODE_ACK, struct.pack(">H", mode))
    assert h.ask(MID.SET_OUTPUT_SETTINGS) == Frame(MID.SET_OUTPUT_SETTINGS_ACK, struct.pack(">I", settings_))
    cfg = Configuration.unpack(h.ask(MID.REQ_CONFIGURATION).payload)
    assert (cfg.output_mode, cfg.output_settings, cfg.sample_period) == (mode, settings_, 288)
    h.ask(MID.GOTO_MEASUREMENT)
    data = [f for f in h.advance(10_000_000) if f.mid == MID.MTDATA]
    assert len(data) == 5 and {len(f.payload) for f in data} == {cfg.mtdata_length} == {36 + 12 + 1 + 2}


def test_legacy_polled_mode_answers_req_data() -> None:
    h = legacy_host()
    h.ask(MID.GOTO_CONFIG)
    h.ask(MID.SET_OUTPUT_SKIP_FACTOR, b"\xff\xff")
    assert h.ask(MID.REQ_DATA) == ERR_04  # ReqData is a measurement-state message
    h.ask(MID.GOTO_MEASUREMENT)
    assert h.dev.output_period_ns is None and h.advance(1_000_000_000) == []
    reply = h.ask(MID.REQ_DATA, t_ns=1_000_000_000)
    assert reply.mid == MID.MTDATA and len(reply.payload) == 18


def test_mk4_legacy_mode_streams_mtdata_until_an_output_configuration_is_set() -> None:
    h = mk4()
    h.ask(MID.GOTO_CONFIG)
    h.ask(MID.SET_OUTPUT_MODE, struct.pack(">H", LegacyMode.ORIENTATION))
    cfg = Configuration.unpack(h.ask(MID.REQ_CONFIGURATION).payload)
    assert cfg.mtdata_length == 18
    h.ask(MID.GOTO_MEASUREMENT)
    assert {f.mid for f in h.advance(50_000_000)} == {MID.MTDATA}
    assert h.send(MID.GOTO_CONFIG, t_ns=60_000_000)[-1] == Frame(MID.GOTO_CONFIG_ACK)  # after the 60 ms sample
    _set_config(h, [(0x2030, 100)])
    assert Configuration.unpack(h.ask(MID.REQ_CONFIGURATION).payload).output_mode == 0


# -- the same exchange fed whole, byte by byte, and with garbage ------------------------------------

MT_MANAGER_SEQUENCE = ["GoToConfig", "SetStringOutputType 0", "SetOutputConfiguration (MT Manager, 12 entries)",
                       "InitMT", "ReqConfiguration", "ReqFWRev", "ReqAvailableFilterProfiles", "ReqEMTS",
                       "ReqAvailableFilterProfiles", "GoToMeasurement"]
GARBAGE = [b"\x00", b"\x13\x37", b"\xfa\xff\x30\x00\x00", b"junk", b"\xff\xff\xff"]


def _replies(chunks: list[bytes]) -> bytes:
    h = mk4()
    for chunk in chunks:
        h.dev.receive(chunk, BOOT)
    return h.dev.take_output()


@pytest.mark.parametrize("feeding", ["whole", "byte_by_byte", "garbage_between_and_trailing"])
def test_device_answers_the_same_however_the_bytes_arrive(feeding: str) -> None:
    frames = [hexb(frame(name)["hex"]) for name in MT_MANAGER_SEQUENCE]
    reference = _replies(frames)
    if feeding == "whole":
        chunks = [b"".join(frames)]
    elif feeding == "byte_by_byte":
        chunks = [bytes((b,)) for b in b"".join(frames)]
    else:
        chunks = [GARBAGE[i % len(GARBAGE)] + f for i, f in enumerate(frames)] + [b"\xfa\xff\x10"]
    assert _replies(chunks) == reference
    assert len(reference) > 1500  # the replies include the 1327-byte eMTS frame


def test_bad_input_while_measuring_is_counted_and_streaming_goes_on() -> None:
    h = mk4()
    rng = np.random.default_rng(5)
    t = 0
    for k in range(40):
        t = k * 2_500_000 + 1_000_000
        junk = rng.integers(0, 256, size=int(rng.integers(1, 30)), dtype=np.uint8).tobytes().replace(b"\xfa", b"")
        h.dev.receive(junk, t)
        h.dev.receive(b"\xfa\xff\x30\xff\x7f\xff", t)  # oversized extended length
        h.dev.receive(encode_frame(MID.SET_OUTPUT_MODE, b"\x00\x04"), t)  # config-only while measuring
    frames = h.frames()
    later = h.advance(1_000_000_000)
    data = [f for f in frames + later if f.mid == MID.MTDATA2]
    assert len(data) == 101 and h.dev.measuring
    assert [f for f in frames if f.mid == MID.ERROR] == [ERR_04] * 40
    c = h.dev.counters
    assert c["oversize_frames"] == 40 and c["wrong_state"] == 40 and c["resync_bytes"] > 0
