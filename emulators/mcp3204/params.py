"""Parameters of the MCP3204 (rig TOML table ``[adc.mcp3204]``)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Mcp3204Params:
    """One MCP3204 on the vehicle's 5 V rail.

    Defaults: VREF tied to the 5 V rail (docs/controllers.md §3.4, docs/protocols.md §3 table),
    an ideal converter (DS21298E Table 1 allows offset and gain errors up to ±1.25 LSB each;
    set them to model a real part).
    """

    __pydantic_config__ = {"extra": "forbid"}

    vref_V: float = 5.0  #: VREF pin voltage at power-up; settable at run time on the device
    vdd_V: float = 5.0  #: supply; DS21298E: VREF must stay within 0.25 V .. VDD
    offset_error_lsb: float = 0.0  #: added to the ideal transition points (±1.25 max)
    gain_error_lsb: float = 0.0  #: deviation at full scale (±1.25 max)
    #: True if the part powers up with CS already low: it then ignores clocks until CS has
    #: been high once (DS21298E §5.0).
    cs_low_at_power_up: bool = False
    #: Max SCK at this VDD (Table 1 conditions: 2 MHz at 5 V, 1 MHz at 2.7 V). Faster clocks
    #: are counted (``sck_over_spec``); the data model does not degrade them.
    f_sck_max_Hz: float = 2.0e6
