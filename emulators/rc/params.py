"""Parameters of the RC chain: PPM receiver, timer-capture front-end, PPM-to-SBUS converter.

Defaults describe the paper's vehicle (a 72 MHz 8-channel PPM receiver) and the common
values in docs/protocols.md section 5.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PpmParams:
    """The receiver's PPM-sum output.

    ``frame_us`` frame period (22.5 ms, OpenSkyRX encoder); ``separator_us`` width of the
    separator pulses (300 us); ``n_channels`` channels per frame; ``idle_high`` True when
    the line idles high with low separators (the common case; ArduPilot's decoder does
    not care); ``min_sync_us`` shortest sync gap the receiver leaves - the frame is
    stretched if the channels would leave less (decoders need >= 2700 us);
    ``jitter_us_rms`` Gaussian jitter on each edge, clipped to +-``jitter_clip_us``;
    ``phase_us`` start of the first frame after sim time 0.
    """

    __pydantic_config__ = {"extra": "forbid"}

    frame_us: int = 22_500
    separator_us: int = 300
    n_channels: int = 8
    idle_high: bool = True
    min_sync_us: int = 3_000
    jitter_us_rms: float = 0.5
    jitter_clip_us: float = 2.0
    phase_us: int = 0

    def __post_init__(self) -> None:
        if not 1 <= self.n_channels <= 16:
            raise ValueError("n_channels must be 1..16")
        if self.separator_us <= 0 or self.frame_us <= 0:
            raise ValueError("separator_us and frame_us must be > 0")
        if self.jitter_us_rms < 0 or self.jitter_clip_us < 0:
            raise ValueError("jitter must be >= 0")
        if 2 * self.jitter_clip_us >= self.separator_us:
            raise ValueError("jitter_clip_us must be well below separator_us")


@dataclass(frozen=True)
class CaptureParams:
    """The timer-capture front-end (an MCU that timestamps PPM edges for the host).

    ``timer_offset_us`` value of the free-running 16-bit 1 MHz timer at sim time 0;
    ``baud`` its UART rate; ``fifo_records`` records it can hold while the UART is busy
    (a full FIFO loses captures: the next record carries the overrun flag);
    ``min_capture_interval_us`` edges closer than this to the previous capture are lost
    (interrupt latency); ``bits_per_byte`` 10 for 8N1.
    """

    __pydantic_config__ = {"extra": "forbid"}

    timer_offset_us: int = 0
    baud: int = 115_200
    fifo_records: int = 32
    min_capture_interval_us: float = 2.0
    bits_per_byte: int = 10

    def __post_init__(self) -> None:
        if self.baud <= 0 or self.fifo_records < 1 or self.bits_per_byte < 8:
            raise ValueError("baud > 0, fifo_records >= 1, bits_per_byte >= 8 required")


@dataclass(frozen=True)
class SbusParams:
    """A PPM-to-SBUS converter.

    ``frame_period_us`` SBUS frame period (14 ms normal speed); ``phase_us`` time of the
    first frame; ``frame_lost_after_us`` a PPM frame counts as missed when the last good
    one is older than this (1.5 PPM frames); ``failsafe_after_us`` the converter's hold
    time with no PPM before it raises failsafe; ``ppm_sync_min_us`` / ``ppm_min_us`` /
    ``ppm_max_us`` / ``ppm_min_channels`` its PPM decoder's rules (ArduPilot's);
    ``default_us`` value of channels the PPM does not carry; ``end_byte`` 0x00 (SBUS1).
    """

    __pydantic_config__ = {"extra": "forbid"}

    frame_period_us: int = 14_000
    phase_us: int = 0
    frame_lost_after_us: int = 34_000
    failsafe_after_us: int = 1_000_000
    ppm_sync_min_us: int = 2_700
    ppm_min_us: int = 700
    ppm_max_us: int = 2_300
    ppm_min_channels: int = 5
    default_us: int = 1_500
    end_byte: int = 0x00
    baud: int = 100_000

    def __post_init__(self) -> None:
        if self.frame_period_us <= 0:
            raise ValueError("frame_period_us must be > 0")
        if not 0 <= self.end_byte <= 0xFF:
            raise ValueError("end_byte must be a byte")
