"""The CPU latency request (hil/host/cpulatency.py): what is written, that it is held for the
block only and not inherited, and a clear refusal where ``cpu_latency = "require"`` asks for
what the host does not give.

The request device is stood in for by a FIFO whose reader records what the request wrote
and sees it closed; the real ``/dev/cpu_dma_latency`` is used where this process may open it."""

from __future__ import annotations

import errno
import os
import struct
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from hil.host.cpulatency import DEVICE, CpuLatencyError, CpuLatencyRequest, LatencyMode, allowed


class FakeDevice:
    """A FIFO standing in for the request device: what was written, and when it was closed."""

    def __init__(self, path: Path) -> None:
        os.mkfifo(path)
        self.path = path
        self.written = bytearray()
        self.closed = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        with open(self.path, "rb", buffering=0) as f:  # blocks until the request opens it
            while chunk := f.read(64):
                self.written += chunk
        self.closed.set()  # EOF: the last writer closed it

    def join(self) -> None:
        self._thread.join(timeout=10)
        assert not self._thread.is_alive()


def _fds_on(path: Path) -> list[str]:
    """This process's descriptors open for writing on ``path`` (the stand-in's reader is not)."""
    out = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            if os.readlink(f"/proc/self/fd/{fd}") != str(path):
                continue
            flags = next(line for line in Path(f"/proc/self/fdinfo/{fd}").read_text().splitlines()
                         if line.startswith("flags:"))
        except OSError:
            continue
        if int(flags.split()[1], 8) & os.O_ACCMODE == os.O_WRONLY:
            out.append(fd)
    return out


def test_auto_holds_the_target_as_a_native_s32_for_the_block_only(tmp_path: Path) -> None:
    dev = FakeDevice(tmp_path / "qos")
    request = CpuLatencyRequest(LatencyMode.AUTO, 7, device=dev.path)
    with request as got:
        assert got.held and got.target_us == 7 and request.holding
        assert got.describe() == "CPU wake-up latency held at 7 us"
        assert len(_fds_on(dev.path)) == 1
        assert not dev.closed.is_set()
    dev.join()
    assert bytes(dev.written) == struct.pack("=i", 7)
    assert dev.closed.is_set() and not request.holding and _fds_on(dev.path) == []


def test_the_request_is_not_inherited_by_what_the_run_starts(tmp_path: Path) -> None:
    """The flight code and the recorder must not keep the request alive after the bench:
    a child started in the block holds no descriptor on the device."""
    dev = FakeDevice(tmp_path / "qos")
    with CpuLatencyRequest(LatencyMode.AUTO, 0, device=dev.path):
        child = subprocess.run(
            [sys.executable, "-c",
             "import os,sys\n"
             "print(sum(os.readlink(f'/proc/self/fd/{fd}') == sys.argv[1] for fd in os.listdir('/proc/self/fd')"
             " if os.path.islink(f'/proc/self/fd/{fd}')))", str(dev.path)],
            capture_output=True, text=True, check=True, close_fds=False)
    assert child.stdout.strip() == "0"
    dev.join()


def test_auto_where_the_device_is_missing_runs_without_and_says_why(tmp_path: Path) -> None:
    missing = tmp_path / "no-such-device"
    with CpuLatencyRequest(LatencyMode.AUTO, 0, device=missing) as got:
        assert not got.held
    assert str(missing) in got.reason and "No such file" in got.reason
    assert got.describe().startswith("CPU wake-up latency not held (")


def _refuse(path: Path, flags: int) -> int:
    raise PermissionError(errno.EACCES, "Permission denied", str(path))


def test_auto_where_the_device_is_not_writable_says_what_it_needs(tmp_path: Path) -> None:
    """As for a user without root (the device is mode 0600 on most distributions)."""
    with CpuLatencyRequest(LatencyMode.AUTO, 0, device=tmp_path / "qos", opener=_refuse) as got:
        assert not got.held
    assert "Permission denied" in got.reason and "needs root or write access to the device" in got.reason
    request = CpuLatencyRequest(LatencyMode.REQUIRE, 0, device=tmp_path / "qos", opener=_refuse)
    with pytest.raises(CpuLatencyError, match="needs root or write access"):
        request.probe()


def test_require_where_refused_is_an_error_before_anything_runs(tmp_path: Path) -> None:
    request = CpuLatencyRequest(LatencyMode.REQUIRE, 0, device=tmp_path / "no-such-device")
    with pytest.raises(CpuLatencyError, match="no-such-device"):
        request.probe()
    with pytest.raises(CpuLatencyError):
        request.__enter__()
    assert not request.holding


def test_require_probe_drops_the_request_at_once(tmp_path: Path) -> None:
    dev = FakeDevice(tmp_path / "qos")
    CpuLatencyRequest(LatencyMode.REQUIRE, 0, device=dev.path).probe()
    dev.join()
    assert dev.closed.is_set() and bytes(dev.written) == struct.pack("=i", 0)


def test_off_never_asks(tmp_path: Path) -> None:
    path = tmp_path / "qos"  # does not exist: opening it would be refused, and nothing is
    with CpuLatencyRequest(LatencyMode.OFF, 0, device=path) as got:
        assert not got.held and got.reason == 'cpu_latency = "off"'
    assert not path.exists()


@pytest.mark.parametrize("target_us", [-1, 2_000_000_001])
def test_targets_out_of_the_kernels_range_are_refused(target_us: int) -> None:
    with pytest.raises(ValueError, match="target_us"):
        CpuLatencyRequest(LatencyMode.AUTO, target_us)


def test_the_real_device_where_this_process_may_open_it() -> None:
    """As CI (root): the kernel takes the request and drops it with the descriptor."""
    if not allowed():
        with CpuLatencyRequest(LatencyMode.AUTO, 0) as got:
            assert not got.held and str(DEVICE) in got.reason
        return
    request = CpuLatencyRequest(LatencyMode.AUTO, 0)
    with request as got:
        assert got.held and len(_fds_on(DEVICE)) == 1
    assert _fds_on(DEVICE) == []
