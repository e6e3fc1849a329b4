"""The Configuration message (0x0D): exactly 118 bytes (docs/protocols.md §1.7).

Layout (big-endian): master device id u32, sample period u16 (1/115200 s), output skip
factor u16, SyncIn mode u16, SyncIn skip factor u16, SyncIn offset u32, date 8 s, time 8 s,
64 reserved bytes, number of devices u16, device id u32, MTData length u16, output mode u16,
output settings u32, 8 trailing bytes. The ethz driver unpacks exactly this layout and
decodes legacy MTData with its length/mode/settings. On mk4 devices the trailing 8 bytes
carry (XDA ``XsMtDeviceConfiguration``): filter profile u16, FW major/minor/revision u8,
filter type char, filter version major/minor u8 - e.g. ``00 27 01 08 02 49 05 01`` on the
golden MTi-300 (profile 39, FW 1.8.2, 'I', 5.1).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

_LAYOUT = struct.Struct(">IHHHHI8s8s64xHIHHI8s")
CONFIGURATION_SIZE = _LAYOUT.size
assert CONFIGURATION_SIZE == 118


@dataclass(frozen=True)
class Configuration:
    """Decoded Configuration message."""

    master_device_id: int
    sample_period: int
    output_skip_factor: int
    device_id: int
    mtdata_length: int
    output_mode: int
    output_settings: int
    trailer: bytes = bytes(8)
    syncin_mode: int = 0
    syncin_skip_factor: int = 0
    syncin_offset: int = 0
    date: bytes = bytes(8)
    time: bytes = bytes(8)
    num_devices: int = 1

    def pack(self) -> bytes:
        return _LAYOUT.pack(
            self.master_device_id, self.sample_period, self.output_skip_factor, self.syncin_mode,
            self.syncin_skip_factor, self.syncin_offset, self.date, self.time, self.num_devices,
            self.device_id, self.mtdata_length, self.output_mode, self.output_settings, self.trailer,
        )

    @classmethod
    def unpack(cls, data: bytes) -> Configuration:
        """Decode; raise ValueError unless ``data`` is exactly 118 bytes."""
        if len(data) != CONFIGURATION_SIZE:
            raise ValueError(f"Configuration must be {CONFIGURATION_SIZE} bytes, got {len(data)}")
        (master, period, skip, sync_mode, sync_skip, sync_offset, date, time, num, did, length, mode,
         settings, trailer) = _LAYOUT.unpack(data)
        return cls(master, period, skip, did, length, mode, settings, trailer, sync_mode, sync_skip,
                   sync_offset, date, time, num)


def mk4_trailer(filter_profile: int, firmware_rev: tuple[int, ...], filter_type: str = "I",
                filter_version: tuple[int, int] = (5, 1)) -> bytes:
    """The 8 trailing bytes an mk4 device puts in its Configuration."""
    major, minor, rev = (tuple(firmware_rev) + (0, 0, 0))[:3]
    return struct.pack(">HBBBcBB", filter_profile, major, minor, rev, filter_type.encode("ascii"),
                       *filter_version)
