"""The firmware's sans-I/O drivers and its mode table, built for the host and driven through
ctypes: the Xbus parser and encoder, MTData2/MTData decoding, the mode machine and the
telemetry payload. Built with firmware/hostlib.py (the firmware's own flags, warnings as
errors) from the sources alone: none of these files touches the hardware layer.
"""

from __future__ import annotations

import ctypes as C
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
FIRMWARE = ROOT / "firmware"
sys.path.insert(0, str(FIRMWARE))
import hostlib  # noqa: E402

SOURCES = ("src/drivers/xbus.c", "src/drivers/mtdata.c", "src/modes.c", "src/telemetry.c", "src/drivers/ppm.c",
           "src/drivers/sbus.c")

XBUS_BUF_SIZE = 512


class XbusCounters(C.Structure):
    _fields_ = [("frames", C.c_uint32), ("garbage_bytes", C.c_uint32), ("checksum_errors", C.c_uint32),
                ("bad_length", C.c_uint32)]


class XbusParserT(C.Structure):
    _fields_ = [("buf", C.c_uint8 * XBUS_BUF_SIZE), ("n", C.c_uint16), ("max_payload", C.c_uint16),
                ("counters", XbusCounters)]


class XbusMsgT(C.Structure):
    _fields_ = [("mid", C.c_uint8), ("len", C.c_uint16), ("payload", C.POINTER(C.c_uint8))]


MSG_FN = C.CFUNCTYPE(None, C.c_void_p, C.POINTER(XbusMsgT))


class XsensDataT(C.Structure):
    _fields_ = [("counter", C.c_uint16), ("has_sample_time_fine", C.c_bool), ("sample_time_fine", C.c_uint32),
                ("euler_deg", C.c_float * 3), ("rate_of_turn_radps", C.c_float * 3),
                ("acceleration_mps2", C.c_float * 3), ("status", C.c_uint32)]


class MtdataCountersT(C.Structure):
    _fields_ = [(name, C.c_uint32) for name in ("mtdata2_truncated", "mtdata2_incomplete", "mtdata_bad_length",
                                                "mtdata_unsupported_layout", "mtdata_incomplete")]


# -- modes (firmware/src/modes.h) --------------------------------------------------------------
MODE_COUNT, EV_COUNT = 6, 9


class ModesParamsT(C.Structure):
    _fields_ = [("gesture_throttle_max_us", C.c_float), ("arm_yaw_min_us", C.c_float),
                ("disarm_yaw_max_us", C.c_float), ("gesture_hold_ns", C.c_int64), ("landed_alt_m", C.c_float),
                ("landed_vz_mps", C.c_float), ("landed_collective_ratio", C.c_float),
                ("landed_accel_mps2", C.c_float), ("landed_ns", C.c_int64), ("auto_disarm_ns", C.c_int64),
                ("takeoff_alt_m", C.c_float)]


class HoldT(C.Structure):
    _fields_ = [("hold_ns", C.c_int64), ("holding", C.c_bool), ("since_ns", C.c_int64)]


class TransitionT(C.Structure):
    _fields_ = [("t_ns", C.c_int64), ("old_mode", C.c_int), ("new_mode", C.c_int), ("event", C.c_int)]


class ModesT(C.Structure):
    _fields_ = [("p", ModesParamsT), ("mode", C.c_int), ("arm", HoldT), ("disarm", HoldT), ("landed", HoldT),
                ("idle", HoldT), ("t_ns", C.c_int64), ("ground_contact", C.c_bool), ("resting", C.c_bool),
                ("resting_since_ns", C.c_int64), ("transitions", TransitionT * 4), ("n_transitions", C.c_uint8)]


class ModesInputT(C.Structure):
    _fields_ = [("baro_ready", C.c_bool), ("rc_valid", C.c_bool), ("throttle_us", C.c_float), ("yaw_us", C.c_float),
                ("z_ref_m", C.c_float), ("z_hat_m", C.c_float), ("vz_hat_mps", C.c_float),
                ("collective", C.c_float), ("hover_collective", C.c_float), ("a_up_mps2", C.c_float)]


# -- telemetry -------------------------------------------------------------------------------------
class TelemetryRecordT(C.Structure):
    _fields_ = [("seq", C.c_uint32), ("t_ns", C.c_int64), ("mode", C.c_uint8), ("flags", C.c_uint16),
                ("euler_rad", C.c_float * 3), ("z_hat_m", C.c_float), ("vz_hat_mps", C.c_float),
                ("z_baro_m", C.c_float), ("roll_ref_rad", C.c_float), ("pitch_ref_rad", C.c_float),
                ("yaw_rate_ref_radps", C.c_float), ("z_ref_m", C.c_float), ("pulses_us", C.c_float * 4),
                ("collective", C.c_float), ("tau_applied_Nm", C.c_float * 3), ("compute_last_us", C.c_float),
                ("compute_max_us", C.c_float), ("compute_mean_us", C.c_float), ("imu_gap_samples", C.c_uint32),
                ("imu_skipped_samples", C.c_uint32), ("adc_failed_reads", C.c_uint32), ("rc_errors", C.c_uint32),
                ("telemetry_dropped", C.c_uint32)]


# -- RC (firmware/src/drivers/ppm.h, sbus.h) ---------------------------------------------------
class EdgeT(C.Structure):
    _fields_ = [("t_us", C.c_uint16), ("seq", C.c_uint8), ("level", C.c_uint8), ("overrun", C.c_bool)]


class CaptureParserT(C.Structure):
    _fields_ = [("buf", C.c_uint8 * 64), ("n", C.c_size_t), ("garbage_bytes", C.c_uint32), ("crc_errors", C.c_uint32),
                ("bad_flags", C.c_uint32)]


class PpmParamsT(C.Structure):
    _fields_ = [("sync_min_us", C.c_uint16), ("pulse_min_us", C.c_uint16), ("pulse_max_us", C.c_uint16),
                ("min_channels", C.c_uint8), ("max_channels", C.c_uint8), ("lock_frames", C.c_uint8),
                ("rising", C.c_bool), ("stale_ms", C.c_float)]


PPM_COUNTERS = ("sequence_gaps", "overruns", "missing_edges", "bad_pulses", "too_many_channels", "short_frames",
                "unlocked_frames", "frames", "locks", "stale_restarts")


class PpmDecoderT(C.Structure):
    _fields_ = [("params", PpmParamsT), *((name, C.c_uint32) for name in PPM_COUNTERS), ("level", C.c_uint8),
                ("have_level", C.c_bool), ("have_t", C.c_bool), ("have_seq", C.c_bool), ("synced", C.c_bool),
                ("last_level", C.c_uint8), ("last_seq", C.c_uint8), ("last_t", C.c_uint16),
                ("channels", C.c_uint16 * 17), ("n_channels", C.c_uint8), ("candidate", C.c_uint8),
                ("stable", C.c_uint8), ("locked_channels", C.c_uint8)]


class SbusFrameT(C.Structure):
    _fields_ = [("raw", C.c_uint16 * 16), ("flags", C.c_uint8)]


class SbusParserT(C.Structure):
    _fields_ = [("buf", C.c_uint8 * 64), ("n", C.c_size_t), ("garbage_bytes", C.c_uint32), ("frames", C.c_uint32)]


SBUS_FN = C.CFUNCTYPE(None, C.c_void_p, C.POINTER(SbusFrameT))


class Codecs:
    """The loaded library with its signatures set."""

    def __init__(self, out_dir: Path) -> None:
        path = hostlib.build_shared([FIRMWARE / s for s in SOURCES], out_dir, "codecs",
                                    include_dirs=(FIRMWARE / "include",))
        d = self.dll = C.CDLL(str(path))
        d.xbus_parser_init.argtypes = [C.POINTER(XbusParserT), C.c_uint16]
        d.xbus_feed.argtypes = [C.POINTER(XbusParserT), C.c_char_p, C.c_size_t, MSG_FN, C.c_void_p]
        d.xbus_feed.restype = C.c_size_t
        d.xbus_bytes_needed.argtypes = [C.POINTER(XbusParserT), C.c_size_t]
        d.xbus_bytes_needed.restype = C.c_size_t
        d.xbus_encode.argtypes = [C.c_uint8, C.c_char_p, C.c_size_t, C.c_char_p, C.c_size_t]
        d.xbus_encode.restype = C.c_size_t
        d.mtdata_decode2.argtypes = [C.c_char_p, C.c_size_t, C.POINTER(XsensDataT), C.POINTER(MtdataCountersT)]
        d.mtdata_decode2.restype = C.c_bool
        d.mtdata_decode_legacy.argtypes = [C.c_char_p, C.c_size_t, C.c_uint16, C.c_uint32, C.POINTER(XsensDataT),
                                           C.POINTER(MtdataCountersT)]
        d.mtdata_decode_legacy.restype = C.c_bool
        d.mtdata_mk4_output_configuration.argtypes = [C.c_uint16, C.c_char_p]
        d.modes_init.argtypes = [C.POINTER(ModesT), C.POINTER(ModesParamsT)]
        d.modes_update.argtypes = [C.POINTER(ModesT), C.c_int64, C.POINTER(ModesInputT)]
        d.modes_update.restype = C.c_int
        d.modes_imu_lost.argtypes = [C.POINTER(ModesT)]
        d.modes_imu_lost.restype = C.c_int
        d.mode_event_name.argtypes = [C.c_int]
        d.mode_event_name.restype = C.c_char_p
        d.mode_name.argtypes = [C.c_int]
        d.mode_name.restype = C.c_char_p
        d.telemetry_encode.argtypes = [C.POINTER(TelemetryRecordT), C.c_char_p]
        d.capture_parser_push.argtypes = [C.POINTER(CaptureParserT), C.c_char_p, C.c_size_t]
        d.capture_parser_push.restype = C.c_size_t
        d.capture_parser_pop.argtypes = [C.POINTER(CaptureParserT), C.POINTER(EdgeT), C.c_size_t]
        d.capture_parser_pop.restype = C.c_size_t
        d.ppm_init.argtypes = [C.POINTER(PpmDecoderT), C.POINTER(PpmParamsT)]
        d.ppm_edge.argtypes = [C.POINTER(PpmDecoderT), C.POINTER(EdgeT), C.POINTER(C.c_uint16)]
        d.ppm_edge.restype = C.c_int
        d.sbus_parser_init.argtypes = [C.POINTER(SbusParserT)]
        d.sbus_parser_feed.argtypes = [C.POINTER(SbusParserT), C.c_char_p, C.c_size_t, SBUS_FN, C.c_void_p]

    # -- Xbus ------------------------------------------------------------------------------------
    def parser(self, max_payload: int = 0xFFFF) -> XbusParser:
        return XbusParser(self, max_payload)

    def encode(self, mid: int, payload: bytes) -> bytes:
        out = C.create_string_buffer(XBUS_BUF_SIZE + 16)
        n = self.dll.xbus_encode(mid, payload, len(payload), out, len(out))
        return out.raw[:n]

    def decode2(self, payload: bytes) -> tuple[XsensDataT | None, MtdataCountersT]:
        data, counters = XsensDataT(), MtdataCountersT()
        ok = self.dll.mtdata_decode2(payload, len(payload), C.byref(data), C.byref(counters))
        return (data if ok else None), counters

    def decode_legacy(self, payload: bytes, mode: int, settings: int) -> tuple[XsensDataT | None, MtdataCountersT]:
        data, counters = XsensDataT(), MtdataCountersT()
        ok = self.dll.mtdata_decode_legacy(payload, len(payload), mode, settings, C.byref(data), C.byref(counters))
        return (data if ok else None), counters

    def mk4_output_configuration(self, rate_hz: int) -> bytes:
        out = C.create_string_buffer(24)
        self.dll.mtdata_mk4_output_configuration(rate_hz, out)
        return out.raw

    # -- modes ----------------------------------------------------------------------------------
    def table(self) -> list[list[int]]:
        arr = (C.c_int8 * (MODE_COUNT * EV_COUNT)).in_dll(self.dll, "MODE_TRANSITIONS")
        return [list(arr[m * EV_COUNT:(m + 1) * EV_COUNT]) for m in range(MODE_COUNT)]

    def motors(self) -> list[int]:
        return list((C.c_int * MODE_COUNT).in_dll(self.dll, "MODE_MOTORS"))

    def at_rest(self) -> list[bool]:
        return list((C.c_bool * MODE_COUNT).in_dll(self.dll, "MODE_AT_REST"))

    # -- telemetry ------------------------------------------------------------------------------
    def telemetry(self, rec: TelemetryRecordT) -> bytes:
        out = C.create_string_buffer(90)
        self.dll.telemetry_encode(C.byref(rec), out)
        return out.raw


class XbusParser:
    """xbus_parser_t with the messages it delivers collected as (mid, payload)."""

    def __init__(self, codecs: Codecs, max_payload: int) -> None:
        self.dll = codecs.dll
        self.p = XbusParserT()
        self.dll.xbus_parser_init(C.byref(self.p), max_payload)
        self._got: list[tuple[int, bytes]] = []

        def on_msg(_ctx: int, msg: C.POINTER(XbusMsgT)) -> None:  # type: ignore[valid-type]
            m = msg.contents
            self._got.append((m.mid, bytes(m.payload[:m.len])))

        self._fn = MSG_FN(on_msg)

    def feed(self, data: bytes) -> list[tuple[int, bytes]]:
        self._got = []
        self.dll.xbus_feed(C.byref(self.p), data, len(data), self._fn, None)
        return self._got

    def feed_all(self, chunks: Iterable[bytes]) -> list[tuple[int, bytes]]:
        out: list[tuple[int, bytes]] = []
        for chunk in chunks:
            out += self.feed(chunk)
        return out

    @property
    def counters(self) -> dict[str, int]:
        c = self.p.counters
        return {name: getattr(c, name) for name, _ in XbusCounters._fields_}

    def bytes_needed(self, default: int) -> int:
        return self.dll.xbus_bytes_needed(C.byref(self.p), default)
