"""The flight code's own XSENS driver (used as an oracle) against the emulator, in process.

Checks the contract between the two: the driver's bring-up succeeds on both identities, and
the samples it decodes are the motion given to ``set_motion`` (NED Euler angles, FRD rates
and specific force), with sensor time from SampleTimeFine / the legacy sample counter.
"""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from emulators.xsens import MtiDevice
from emulators.xsens.frames import euler_deg_to_quat, rotate_inv
from emulators.xsens.params import Identity
from flightcode.drivers.xsens import ImuParams, XsensDriver
from flightcode.log import Logger
from tests.unit.xsens.host import exact_params

TICK_NS = 2_500_000


class InProcessPort:
    """The pyserial subset the driver uses, wired straight to the device (no waiting)."""

    def __init__(self, device: MtiDevice) -> None:
        self.dev = device
        self.buf = bytearray()
        self.t_ns = -1_000_000_000

    def _pull(self) -> None:
        self.buf += self.dev.take_output()

    @property
    def in_waiting(self) -> int:
        self._pull()
        return len(self.buf)

    @property
    def out_waiting(self) -> int:
        return 0

    def read(self, size: int = 1) -> bytes:
        self._pull()
        data = bytes(self.buf[:size])
        del self.buf[:size]
        return data

    def write(self, data: bytes) -> int:
        self.dev.receive(data, self.t_ns)
        return len(data)

    def reset_input_buffer(self) -> None:
        self._pull()
        self.buf.clear()

    def close(self) -> None:
        pass


@pytest.mark.parametrize("identity", [Identity.MK4, Identity.LEGACY])
def test_flight_code_driver_brings_up_and_reads_the_motion(identity: Identity) -> None:
    dev = MtiDevice(exact_params(identity=identity), np.random.default_rng(0))
    port = InProcessPort(dev)
    log = io.StringIO()
    drv = XsensDriver(port, ImuParams(identity=identity.value, reply_timeout_s=0.5), Logger(log))
    info = drv.bring_up()
    drv.start()
    assert info.device_id == (0x037003F8 if identity is Identity.MK4 else 0x00500A2B)
    assert dev.measuring and dev.output_period_ns == TICK_NS
    q = euler_deg_to_quat(5.0, -3.0, 120.0)
    omega, f = (0.05, -0.1, 0.2), rotate_inv(q, (0.0, 0.0, -9.80665))
    for k in range(8):
        dev.set_motion(q, omega, f)
        dev.advance(k * TICK_NS)
        sample = drv.read_sample(timeout_s=0.5)
        assert sample is not None
        assert sample.t_ns == k * TICK_NS and sample.counter == k and sample.skipped == 0
        assert sample.euler_rad == pytest.approx(tuple(math.radians(a) for a in (5.0, -3.0, 120.0)), abs=1e-6)
        assert sample.omega_B_radps == pytest.approx(omega, abs=1e-6)
        assert sample.f_B_mps2 == pytest.approx(f, abs=1e-5)
    assert drv.counters["gap_samples"] == 0 and drv.counters["unexpected_messages"] == 0
    assert dev.counters["errors_sent"] == 0 and dev.counters["unknown_mids"] == 0
