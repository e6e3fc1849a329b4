"""A minimal sans-I/O host for driving an MtiDevice in unit tests."""

from __future__ import annotations

from dataclasses import replace
from typing import TypeVar

import numpy as np

from emulators.base import DeviceEvent
from emulators.xsens.codec import Frame, FrameParser, encode_frame
from emulators.xsens.device import MtiDevice
from emulators.xsens.params import XsensParams

E = TypeVar("E", bound=DeviceEvent)

#: Parameters without any sensor error, for exact value checks.
EXACT = dict(
    gyro_noise_radps_per_rthz=0.0, acc_noise_mps2_per_rthz=0.0, gyro_bias_sigma_radps=0.0,
    gyro_bias_rw_radps_per_rts=0.0, acc_bias_sigma_mps2=0.0, orientation_bias_rp_deg=0.0,
    orientation_bias_yaw_deg=0.0, orientation_noise_deg=0.0,
)


def exact_params(**kw: object) -> XsensParams:
    return replace(XsensParams(**EXACT), **kw)  # type: ignore[arg-type]


class Host:
    """Sends frames to a device and parses what comes back."""

    def __init__(self, device: MtiDevice) -> None:
        self.dev = device
        self.parser = FrameParser(max_payload=8192)
        self.events: list[DeviceEvent] = []

    @classmethod
    def make(cls, params: XsensParams | None = None, seed: int = 1) -> Host:
        return cls(MtiDevice(params or exact_params(), np.random.default_rng(seed)))

    def raw(self) -> bytes:
        out = self.dev.take_output()
        self.events += self.dev.take_events()
        return out

    def frames(self) -> list[Frame]:
        return self.parser.feed(self.raw())

    def send(self, mid: int, payload: bytes = b"", t_ns: int = -1_000_000_000) -> list[Frame]:
        self.dev.receive(encode_frame(mid, payload), t_ns)
        return self.frames()

    def ask(self, mid: int, payload: bytes = b"", t_ns: int = -1_000_000_000) -> Frame:
        """Send and return the single reply."""
        replies = self.send(mid, payload, t_ns)
        assert len(replies) == 1, replies
        return replies[0]

    def advance(self, t_ns: int) -> list[Frame]:
        self.dev.advance(t_ns)
        return self.frames()

    def of_type(self, kind: type[E]) -> list[E]:
        return [e for e in self.events if isinstance(e, kind)]
