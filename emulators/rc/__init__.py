"""RC input chain: stick script -> PPM pulse train -> capture or SBUS front-end.

See docs/rc-capture-format.md for the capture record format the flight code reads.
"""

from emulators.rc.capture import (
    CaptureFlag,
    CaptureFrontEnd,
    CaptureLost,
    CaptureRecord,
    CaptureWire,
    crc8,
    pack_record,
    unpack_record,
)
from emulators.rc.params import CaptureParams, PpmParams, SbusParams
from emulators.rc.ppm import PpmEdge, PpmFrame, PpmGenerator
from emulators.rc.sbus import (
    PpmDecoded,
    PpmDecoder,
    SbusConverter,
    SbusFlag,
    SbusFrame,
    SbusWire,
    pack_sbus,
    pwm_to_raw,
    raw_to_pwm,
    unpack_sbus,
)
from emulators.rc.script import (
    Channel,
    Loss,
    Macro,
    MacroName,
    Setpoint,
    Sine,
    StickScript,
)

__all__ = [
    "CaptureFlag", "CaptureFrontEnd", "CaptureLost", "CaptureParams", "CaptureRecord", "CaptureWire",
    "Channel", "Loss", "Macro", "MacroName", "PpmDecoded", "PpmDecoder", "PpmEdge", "PpmFrame",
    "PpmGenerator", "PpmParams", "SbusConverter", "SbusFlag", "SbusFrame", "SbusParams", "SbusWire",
    "Setpoint", "Sine", "StickScript", "crc8", "pack_record", "pack_sbus", "pwm_to_raw", "raw_to_pwm",
    "unpack_record", "unpack_sbus",
]
