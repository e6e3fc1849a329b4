"""Parameters of the Bus Pirate bridge (rig TOML table ``[adc.buspirate]``)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BusPirateParams:
    """A Bus Pirate v3.5 with firmware v6.1, its SPI pins wired to the MCP3204.

    The identity strings are what the terminal prints after a reset; flashrom parses the
    word after "irate " (hardware) and after "irmware " (firmware version, which selects
    its code paths: >= 5.5 write-then-read, < 6.2 SPI speed capped at 2 MHz).
    """

    __pydantic_config__ = {"extra": "forbid"}

    baud_bps: int = 115200  #: terminal/binary UART rate (FT232 <-> PIC)
    hardware: str = "v3.5"
    firmware: str = "v6.1 r1676"
    bootloader: str = "v4.4"
    device_id: str = "DEVID:0x0447 REVID:0x3046 (24FJ64GA002 B8)"
    #: Largest write-then-read length (firmware TERMINAL_BUFFER); longer -> 0x00.
    write_then_read_max_bytes: int = 4096
    #: Answer the read-back commands 0x50/0x70/0x90 listed on the DP wiki SPI (binary) page
    #: with the current setting (in the form of the matching set command byte). The v6.x
    #: firmware source for the v3 has no such cases and answers 0x00: set False for that.
    readback_commands: bool = True
    #: The target board pulls CS/CLK/MOSI up, so the default open-drain (HiZ) output works
    #: without the Bus Pirate's own pull-ups. The MCP3204 board has none by default: the
    #: host must select 3.3 V push-pull outputs (config 0x8A) or switch the pull-ups on.
    target_pullups: bool = False
    #: Errors the binary self-test reports (0 = all good).
    selftest_errors: int = 0
