"""Hold the host's CPUs out of deep idle while a run flies (the kernel's CPU latency QoS).

Every hop of a tick wakes a process on a CPU that was idle: the bench writes the IMU sample
and the flight code, asleep in ``select``, must be woken; the flight code's ADC request wakes
the bench; and so on, three to four times a tick. An idle CPU that has entered an idle state
must first leave it, and on a virtual machine that leaves the guest for the hypervisor
(``cpuidle-haltpoll``'s halt): a trace of a realtime tick here showed 40-60 us from a pty write
to the kernel's flush work running on the idle CPU. The caches of a CPU that was halted are
also colder. Holding a CPU latency request of 0 us makes the idle governor poll instead
(``idle=poll`` for the duration), as ``cyclictest`` and ``rtla timerlat --dma-latency`` do.

What it gains on the machine at hand (lockstep RTF, the bench's CPU per tick, realtime
response) is measured with interleaved pairs of recorded hovers with and without it
(docs/time.md says how).

The request is an open file: the kernel keeps it while ``/dev/cpu_dma_latency`` is open and
drops it when it is closed, by this process's exit too, so a crash cannot leave it behind.
The descriptor is not inherited (PEP 446): the flight code and the recorder hold none.

The cost: idle CPUs spin for the run's length instead of sleeping (power, heat, a VM's
neighbours). Runs are short; ``cpu_latency = "off"`` in the rig's ``[host]`` table never asks.

Permission: the device is root's (mode 0600 on most distributions). ``cpu_latency = "auto"``
(the default) holds the request where it may and otherwise runs as before, saying so in the
run's summary; ``"require"`` refuses to run without it; ``"off"`` never asks.
"""

from __future__ import annotations

import enum
import errno
import os
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hil.config.rig import Rig

#: the CPU latency QoS device (Documentation/power/pm_qos_interface.rst)
DEVICE = Path("/dev/cpu_dma_latency")
#: the largest target the kernel takes: PM_QOS_CPU_LATENCY_DEFAULT_VALUE, 2000 s in us
MAX_TARGET_US = 2_000_000_000

#: what the device is opened through (tests put a refusing one in its place)
Opener = Callable[[Path, int], int]


class LatencyMode(enum.Enum):
    AUTO = "auto"  #: hold the request where the host allows it, else run without
    REQUIRE = "require"  #: hold it or no run
    OFF = "off"  #: never ask


class CpuLatencyError(Exception):
    """``cpu_latency = "require"`` on a host that does not allow it (the message says why)."""


@dataclass(frozen=True)
class CpuLatency:
    """What a run got: the request held at ``target_us``, or not and why."""

    held: bool
    target_us: int = 0
    reason: str = ""  #: why not held (empty when it is)

    def describe(self) -> str:
        if self.held:
            return f"CPU wake-up latency held at {self.target_us} us"
        return f"CPU wake-up latency not held ({self.reason})"


class CpuLatencyRequest:
    """Hold a CPU latency request of ``target_us`` for the ``with`` block."""

    def __init__(self, mode: LatencyMode, target_us: int = 0, *, device: Path | None = None,
                 opener: Opener | None = None) -> None:
        if not 0 <= target_us <= MAX_TARGET_US:
            raise ValueError(f"target_us must be 0..{MAX_TARGET_US}, not {target_us}")
        self.mode = mode
        self.target_us = target_us
        self.device = device or DEVICE
        self._open: Opener = opener or os.open
        self._fd: int | None = None
        self.result: CpuLatency | None = CpuLatency(False, 0, 'cpu_latency = "off"') if mode is LatencyMode.OFF else None

    def probe(self) -> None:
        """``cpu_latency = "require"``: raise :class:`CpuLatencyError` now if the host refuses
        the request, before a run creates anything (the request is dropped at once)."""
        if self.mode is LatencyMode.REQUIRE:
            with CpuLatencyRequest(LatencyMode.REQUIRE, self.target_us, device=self.device, opener=self._open):
                pass

    def __enter__(self) -> CpuLatency:
        if self.mode is LatencyMode.OFF:
            assert self.result is not None
            return self.result
        try:
            fd = self._open(self.device, os.O_WRONLY | os.O_CLOEXEC)
        except OSError as exc:
            return self._refused(exc)
        value = struct.pack("=i", self.target_us)  # a native s32 in microseconds
        try:
            if os.write(fd, value) != len(value):
                raise OSError(errno.EIO, "the request was not taken whole")
        except OSError as exc:
            os.close(fd)
            return self._refused(exc)
        self._fd = fd
        self.result = CpuLatency(True, self.target_us)
        return self.result

    def _refused(self, exc: OSError) -> CpuLatency:
        why = (f"{self.device}: {exc.strerror or exc}; holding it needs root or write access to the device"
               if exc.errno in (errno.EACCES, errno.EPERM) else f"{self.device}: {exc.strerror or exc}")
        if self.mode is LatencyMode.REQUIRE:
            raise CpuLatencyError(why) from exc
        self.result = CpuLatency(False, 0, why)
        return self.result

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)  # the kernel drops the request with the last reference to the file

    @property
    def holding(self) -> bool:
        return self._fd is not None


def for_rig(rig: Rig) -> CpuLatencyRequest:
    """The rig's ``[host]`` CPU latency request for a run. ``cpu_latency = "require"`` on a host
    that refuses it is a :class:`~hil.config.ConfigError` naming the rig file and the key,
    raised here, before the run creates anything."""
    from hil.config import ConfigError

    section = rig.host
    request = CpuLatencyRequest(LatencyMode(section.cpu_latency), section.cpu_latency_us)
    try:
        request.probe()
    except CpuLatencyError as exc:
        raise ConfigError(f"{rig.path}: [host] cpu_latency = \"require\": {exc}") from None
    return request


def allowed(target_us: int = 0) -> bool:
    """Whether this process may hold a request of ``target_us`` (it is dropped at once)."""
    with CpuLatencyRequest(LatencyMode.AUTO, target_us) as got:
        return got.held
