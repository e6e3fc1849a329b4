"""Parameters of the Pololu Maestro servo controller (Mini Maestro 12 driving four ESCs)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MaestroParams:
    """Settings as configured in the Maestro Control Center.

    Targets are in quarter-microseconds (qus). ``device_number`` Pololu-protocol address
    (default 12); ``n_channels`` 6/12/18/24; ``crc_enabled`` every non-Mini-SSC packet
    carries a CRC-7 byte; ``min_target_qus``/``max_target_qus`` channel limits (Maestro
    defaults 992/2000 us); ``neutral_qus``/``range_qus`` Mini SSC 8-bit neutral and range
    (defaults 1500 us and 476.25 us); ``mini_ssc_offset`` first Mini SSC servo address;
    ``home_qus`` home target of every channel, 0 = off (no pulses); ``home_on_error`` the
    Maestro sends channels home when an error bit is set; ``update_period_us`` period of
    the speed/acceleration updates (10 ms); ``serial_timeout_ms`` 0 = disabled, else a
    serial-timeout error after that long without a valid command; ``usb_command_port``
    True for the USB virtual COM port (line rate ignored), False for the TTL UART at a
    fixed ``baud``.
    """

    __pydantic_config__ = {"extra": "forbid"}

    device_number: int = 12
    n_channels: int = 12
    crc_enabled: bool = False
    min_target_qus: int = 3968
    max_target_qus: int = 8000
    neutral_qus: int = 6000
    range_qus: int = 1905
    mini_ssc_offset: int = 0
    home_qus: int = 0
    home_on_error: bool = True
    update_period_us: int = 10_000
    serial_timeout_ms: int = 0
    usb_command_port: bool = True
    baud: int = 115_200

    def __post_init__(self) -> None:
        if not 0 <= self.device_number <= 0x7F:
            raise ValueError("device_number must be 0..127")
        if self.n_channels not in (6, 12, 18, 24):
            raise ValueError("n_channels must be 6, 12, 18 or 24")
        if not 0 < self.min_target_qus <= self.max_target_qus < 0x4000:
            raise ValueError("need 0 < min_target_qus <= max_target_qus < 16384")
        if self.update_period_us <= 0 or self.serial_timeout_ms < 0:
            raise ValueError("update_period_us > 0 and serial_timeout_ms >= 0 required")
