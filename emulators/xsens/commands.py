"""Config-state requests: the stored settings and the replies that carry them.

Requests and sets share a MID and differ by length (Req = LEN 0); a set is acknowledged
with MID + 1 and no data (MT0100P §5.3.2 example: SetOutputModeAck ``FA FF D1 00 30``). A
length that fits neither form is answered with Error 0x04, like an unknown or unsupported
MID. Which messages each identity knows is in :data:`SUPPORTED`; state-machine messages
(GoToConfig, GoToMeasurement, Reset, WakeUpAck, ReqData) are handled by the device.
"""

from __future__ import annotations

import hashlib
import struct
from collections.abc import Callable
from dataclasses import dataclass, replace

from emulators.xsens import legacy
from emulators.xsens.config_msg import Configuration, mk4_trailer
from emulators.xsens.defs import BAUD_BPS_BY_CODE, MID, BaudCode, ErrorCode, ErrorMode
from emulators.xsens.frames import Q_IDENTITY, Quat, quat_normalize
from emulators.xsens.output_config import (
    SKIP_POLLED,
    apply_output_configuration,
    encode_entries,
    legacy_period_error,
    parse_entries,
)
from emulators.xsens.params import Identity, ResolvedIdentity, XsensParams

#: Self-test result: all nine sensor axes passed (golden MTi-300: 0x01FF).
SELFTEST_ALL_OK = 0x01FF
#: Baud codes each identity accepts (legacy: 9600..921600; mk4 up to 2 Mbit/s).
BAUD_CODES: dict[Identity, frozenset[int]] = {
    Identity.LEGACY: frozenset(range(0x00, 0x0B)) | {BaudCode.B921600_LEGACY},
    Identity.MK4: frozenset(range(0x00, 0x0D)) | {BaudCode.B921600_LEGACY},
}


@dataclass(frozen=True)
class Settings:
    """What the device stores (survives Reset and power cycles)."""

    baud_code: int
    output_configuration: tuple[tuple[int, int], ...]
    output_mode: int
    output_settings: int
    period: int
    skip_factor: int
    error_mode: int
    filter_profile: int
    option_flags: int = 0
    location_id: int = 0
    string_output_type: int = 0
    sync_settings: bytes = b""
    alignment: tuple[Quat, Quat] = (Q_IDENTITY, Q_IDENTITY)  #: (sensor, local)


@dataclass(frozen=True)
class Reply:
    """Outcome of a request: the reply (MID + data) or an error, and any new settings."""

    mid: int | None = None
    payload: bytes = b""
    error: ErrorCode | None = None
    settings: Settings | None = None


def factory_settings(params: XsensParams, ident: ResolvedIdentity, baud_code: int) -> Settings:
    return Settings(
        baud_code=baud_code,
        output_configuration=apply_output_configuration(ident.output_configuration, params.sample_rate_hz),
        output_mode=ident.legacy_output_mode,
        output_settings=ident.legacy_output_settings,
        period=params.legacy_period,
        skip_factor=params.legacy_skip_factor,
        error_mode=ident.error_mode,
        filter_profile=params.filter_profile,
    )


def legacy_active(identity: Identity, s: Settings) -> bool:
    """Whether the device streams MTData (legacy identity, or an mk4 in legacy mode)."""
    return identity is Identity.LEGACY or s.output_mode != 0


def emts_blob(device_id: int, size: int) -> bytes:
    """The opaque eMTS (calibration) data: deterministic per device id, content not modelled."""
    out, counter = bytearray(), 0
    while len(out) < size:
        out += hashlib.blake2b(struct.pack(">II", device_id, counter), digest_size=64).digest()
        counter += 1
    return bytes(out[:size])


_Handler = Callable[["Commands", bytes, Settings], Reply]
_ANY = None  # any length accepted by the handler itself


class Commands:
    """Handles the request/set messages valid in Config state."""

    def __init__(self, params: XsensParams, ident: ResolvedIdentity) -> None:
        self.p = params
        self.ident = ident
        self.identity = Identity(params.identity)

    # -- dispatch ---------------------------------------------------------------------------
    def supports(self, mid: int) -> bool:
        return mid in SUPPORTED[self.identity]

    def handle(self, mid: int, payload: bytes, s: Settings) -> Reply:
        handler, lengths = _TABLE[MID(mid)]
        if lengths is not _ANY and len(payload) not in lengths:
            return Reply(error=ErrorCode.INVALID_MESSAGE)
        return handler(self, payload, s)

    # -- identity ---------------------------------------------------------------------------
    def _did(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.DEVICE_ID, self.ident.device_id.to_bytes(4, "big"))

    def _init_mt(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.INIT_MT_RESULTS, self.ident.device_id.to_bytes(4, "big"))

    def _product_code(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.PRODUCT_CODE, self.ident.product_code.encode("ascii")[:20].ljust(20, b" "))

    def _fw_rev(self, payload: bytes, s: Settings) -> Reply:
        fw = self.ident.firmware_rev
        data = bytes(fw[:3]) + (struct.pack(">II", *fw[3:5]) if len(fw) >= 5 else b"")
        return Reply(MID.FIRMWARE_REV, data)

    def _hw_version(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.HARDWARE_VERSION, bytes(self.ident.hardware_version))

    def _selftest(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.SELFTEST_RESULTS, SELFTEST_ALL_OK.to_bytes(2, "big"))

    def configuration(self, s: Settings) -> Configuration:
        """The Configuration record; legacy fields match the MTData actually streamed."""
        active = legacy_active(self.identity, s)
        did = self.ident.device_id
        trailer = bytes(8) if self.identity is Identity.LEGACY else mk4_trailer(s.filter_profile,
                                                                                  self.ident.firmware_rev)
        return Configuration(
            master_device_id=did, sample_period=s.period, output_skip_factor=s.skip_factor, device_id=did,
            mtdata_length=legacy.mtdata_length(s.output_mode, s.output_settings) if active else 0,
            output_mode=s.output_mode, output_settings=s.output_settings, trailer=trailer,
        )

    def _configuration(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.CONFIGURATION, self.configuration(s).pack())

    def _restore_factory(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.RESTORE_FACTORY_DEF_ACK, settings=factory_settings(self.p, self.ident, BaudCode.B115200))

    # -- line and error handling ------------------------------------------------------------
    def _baudrate(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_BAUDRATE_ACK, bytes((s.baud_code,)))
        code = payload[0]
        if code not in BAUD_CODES[self.identity] or code not in BAUD_BPS_BY_CODE:
            return Reply(error=ErrorCode.BAUDRATE_INVALID)
        return Reply(MID.SET_BAUDRATE_ACK, settings=replace(s, baud_code=code))

    def _error_mode(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_ERROR_MODE_ACK, s.error_mode.to_bytes(2, "big"))
        mode = int.from_bytes(payload, "big")
        if mode not in ErrorMode._value2member_map_:
            return Reply(error=ErrorCode.INVALID_PARAM)
        return Reply(MID.SET_ERROR_MODE_ACK, settings=replace(s, error_mode=mode))

    def _option_flags(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_OPTION_FLAGS_ACK, s.option_flags.to_bytes(4, "big"))
        set_flags, clear_flags = struct.unpack(">II", payload)
        return Reply(MID.SET_OPTION_FLAGS_ACK,
                     settings=replace(s, option_flags=(s.option_flags | set_flags) & ~clear_flags & 0xFFFF_FFFF))

    def _location_id(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_LOCATION_ID_ACK, s.location_id.to_bytes(2, "big"))
        return Reply(MID.SET_LOCATION_ID_ACK, settings=replace(s, location_id=int.from_bytes(payload, "big")))

    def _string_output(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_STRING_OUTPUT_TYPE_ACK, s.string_output_type.to_bytes(2, "big"))
        value = int.from_bytes(payload, "big")
        if value:  # NMEA string output is not emulated
            return Reply(error=ErrorCode.INVALID_PARAM)
        return Reply(MID.SET_STRING_OUTPUT_TYPE_ACK, settings=replace(s, string_output_type=value))

    # -- mk4 output configuration and filter -------------------------------------------------
    def _output_configuration(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.OUTPUT_CONFIGURATION, encode_entries(s.output_configuration))
        entries, err = parse_entries(payload)
        if err is not None:
            return Reply(error=err)
        applied = apply_output_configuration(entries, self.p.sample_rate_hz)
        # The MTData2 list supersedes the legacy output mode (MT0605P §5.3.3).
        return Reply(MID.OUTPUT_CONFIGURATION, encode_entries(applied),
                     settings=replace(s, output_configuration=applied, output_mode=0))

    def _filter_profiles(self, payload: bytes, s: Settings) -> Reply:
        data = b"".join(bytes((kind, version)) + label.encode("ascii")[:20].ljust(20, b" ")
                        for kind, version, label in self.p.filter_profiles)
        return Reply(MID.AVAILABLE_FILTER_PROFILES, data)

    def _filter_profile(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_FILTER_PROFILE_ACK, s.filter_profile.to_bytes(2, "big"))
        value = int.from_bytes(payload, "big")
        if (value & 0xFF) not in {kind for kind, _, _ in self.p.filter_profiles}:
            return Reply(error=ErrorCode.INVALID_FILTER_PROFILE)
        return Reply(MID.SET_FILTER_PROFILE_ACK, settings=replace(s, filter_profile=value))

    def emts(self) -> bytes:
        return emts_blob(self.ident.device_id, self.p.emts_size_bytes)

    def _emts(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.EMTS_DATA, self.emts())

    def _sync_settings(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_SYNC_SETTINGS_ACK, s.sync_settings)
        if len(payload) % 12 or len(payload) > 120:
            return Reply(error=ErrorCode.INVALID_MESSAGE)
        return Reply(MID.SET_SYNC_SETTINGS_ACK, settings=replace(s, sync_settings=bytes(payload)))

    def _alignment(self, payload: bytes, s: Settings) -> Reply:
        frame = payload[0]
        if frame > 1:
            return Reply(error=ErrorCode.INVALID_PARAM)
        if len(payload) == 1:
            return Reply(MID.SET_ALIGNMENT_ROTATION_ACK, bytes((frame,)) + struct.pack(">4f", *s.alignment[frame]))
        q = quat_normalize(struct.unpack(">4f", payload[1:17]))
        alignment = (q, s.alignment[1]) if frame == 0 else (s.alignment[0], q)
        return Reply(MID.SET_ALIGNMENT_ROTATION_ACK, settings=replace(s, alignment=alignment))

    # -- legacy output ----------------------------------------------------------------------
    def _output_mode(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_OUTPUT_MODE_ACK, s.output_mode.to_bytes(2, "big"))
        mode = int.from_bytes(payload, "big")
        if (err := legacy.validate(mode, s.output_settings)) is not None:
            return Reply(error=err)
        return Reply(MID.SET_OUTPUT_MODE_ACK, settings=replace(s, output_mode=mode))

    def _output_settings(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_OUTPUT_SETTINGS_ACK, s.output_settings.to_bytes(4, "big"))
        settings = int.from_bytes(payload, "big")
        if (err := legacy.validate(s.output_mode, settings)) is not None:
            return Reply(error=err)
        return Reply(MID.SET_OUTPUT_SETTINGS_ACK, settings=replace(s, output_settings=settings))

    def _period(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_PERIOD_ACK, s.period.to_bytes(2, "big"))
        period = int.from_bytes(payload, "big")
        if (err := legacy_period_error(period, s.skip_factor, self.p.sample_rate_hz)) is not None:
            return Reply(error=err)
        return Reply(MID.SET_PERIOD_ACK, settings=replace(s, period=period))

    def _skip_factor(self, payload: bytes, s: Settings) -> Reply:
        if not payload:
            return Reply(MID.SET_OUTPUT_SKIP_FACTOR_ACK, s.skip_factor.to_bytes(2, "big"))
        skip = int.from_bytes(payload, "big")
        if skip != SKIP_POLLED and legacy_period_error(s.period, skip, self.p.sample_rate_hz) is not None:
            return Reply(error=ErrorCode.INVALID_PERIOD)
        return Reply(MID.SET_OUTPUT_SKIP_FACTOR_ACK, settings=replace(s, skip_factor=skip))

    def _data_length(self, payload: bytes, s: Settings) -> Reply:
        return Reply(MID.DATA_LENGTH, legacy.mtdata_length(s.output_mode, s.output_settings).to_bytes(2, "big"))


#: MID -> (handler, accepted payload lengths).
_TABLE: dict[MID, tuple[_Handler, frozenset[int] | None]] = {
    MID.REQ_DID: (Commands._did, frozenset({0})),
    MID.INIT_MT: (Commands._init_mt, frozenset({0})),
    MID.REQ_PRODUCT_CODE: (Commands._product_code, frozenset({0})),
    MID.REQ_FW_REV: (Commands._fw_rev, frozenset({0})),
    MID.REQ_HARDWARE_VERSION: (Commands._hw_version, frozenset({0})),
    MID.RUN_SELFTEST: (Commands._selftest, frozenset({0})),
    MID.REQ_CONFIGURATION: (Commands._configuration, frozenset({0})),
    MID.RESTORE_FACTORY_DEF: (Commands._restore_factory, frozenset({0})),
    MID.SET_BAUDRATE: (Commands._baudrate, frozenset({0, 1})),
    MID.SET_ERROR_MODE: (Commands._error_mode, frozenset({0, 2})),
    MID.SET_OPTION_FLAGS: (Commands._option_flags, frozenset({0, 8})),
    MID.SET_LOCATION_ID: (Commands._location_id, frozenset({0, 2})),
    MID.SET_STRING_OUTPUT_TYPE: (Commands._string_output, frozenset({0, 2})),
    MID.SET_OUTPUT_CONFIGURATION: (Commands._output_configuration, _ANY),
    MID.REQ_AVAILABLE_FILTER_PROFILES: (Commands._filter_profiles, frozenset({0})),
    MID.SET_FILTER_PROFILE: (Commands._filter_profile, frozenset({0, 2})),
    MID.REQ_EMTS: (Commands._emts, frozenset({0, 2})),
    MID.SET_SYNC_SETTINGS: (Commands._sync_settings, _ANY),
    MID.SET_ALIGNMENT_ROTATION: (Commands._alignment, frozenset({1, 17})),
    MID.SET_OUTPUT_MODE: (Commands._output_mode, frozenset({0, 2})),
    MID.SET_OUTPUT_SETTINGS: (Commands._output_settings, frozenset({0, 4})),
    MID.SET_PERIOD: (Commands._period, frozenset({0, 2})),
    MID.SET_OUTPUT_SKIP_FACTOR: (Commands._skip_factor, frozenset({0, 2})),
    MID.REQ_DATA_LENGTH: (Commands._data_length, frozenset({0})),
}

_COMMON = frozenset({
    MID.REQ_DID, MID.INIT_MT, MID.REQ_PRODUCT_CODE, MID.REQ_FW_REV, MID.REQ_HARDWARE_VERSION, MID.RUN_SELFTEST,
    MID.REQ_CONFIGURATION, MID.RESTORE_FACTORY_DEF, MID.SET_BAUDRATE, MID.SET_ERROR_MODE, MID.SET_LOCATION_ID,
    MID.SET_OUTPUT_MODE, MID.SET_OUTPUT_SETTINGS, MID.SET_PERIOD, MID.SET_OUTPUT_SKIP_FACTOR,
})
#: Config-state messages each identity answers; anything else gets Error 0x04. The
#: legacy MTi lacks the mk4 additions (ethz expects 0x04 from a "mark III" device for C0,
#: 8E, ...); mk4 devices answer ReqDataLength with 0x04 (ethz, docs/protocols.md §1.4).
SUPPORTED: dict[Identity, frozenset[MID]] = {
    Identity.LEGACY: _COMMON | {MID.REQ_DATA_LENGTH},
    Identity.MK4: _COMMON | {
        MID.SET_OUTPUT_CONFIGURATION, MID.SET_OPTION_FLAGS, MID.SET_STRING_OUTPUT_TYPE,
        MID.REQ_AVAILABLE_FILTER_PROFILES, MID.SET_FILTER_PROFILE, MID.REQ_EMTS, MID.SET_SYNC_SETTINGS,
        MID.SET_ALIGNMENT_ROTATION,
    },
}
