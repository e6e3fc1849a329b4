"""Analog front-end: MPX5100AP and ADXL335 models, signal conditioning, the four ADC pins."""

from emulators.analog.frontend import AccelFault, AnalogFrontEnd, BaroFault
from emulators.analog.params import (
    AnalogParams,
    Adxl335Params,
    ConditioningParams,
    Mpx5100apParams,
    baro_offset_V_for_field,
)

__all__ = [
    "AccelFault",
    "AnalogFrontEnd",
    "AnalogParams",
    "Adxl335Params",
    "BaroFault",
    "ConditioningParams",
    "Mpx5100apParams",
    "baro_offset_V_for_field",
]
