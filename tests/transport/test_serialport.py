"""SerialPort on real serial lines: a null-modem pty pair and a loopback socket://."""

from __future__ import annotations

import asyncio
import errno
import fcntl
import os
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest
import serial

from hil.config import ConfigError
from hil.transport.serialport import (
    Framing,
    PortOpenError,
    SerialPort,
    latency_timer_note,
    set_low_latency,
    usb_latency_timer_ms,
)
from tests.transport import conformance
from tests.transport.nullmodem import LoopbackServer, loopback_server, null_modem
from tests.transport.test_conformance import SerialClient

pytestmark = [pytest.mark.pty]

FRAMING = Framing(115200)


def nullmodem_harness(tmp_path: Path):
    @asynccontextmanager
    async def make() -> AsyncIterator[tuple[SerialPort, SerialClient]]:
        async with null_modem(tmp_path) as (bench_end, client_end):
            port = SerialPort("imu", bench_end, FRAMING)
            await port.start()
            client = SerialClient(client_end)
            try:
                yield port, client
            finally:
                await client.close()
                port.close()

    return make


class SocketClient:
    def __init__(self, server: LoopbackServer) -> None:
        self.server = server

    async def open(self, baud: int) -> None:
        if self.server.sock is None:
            await self.server.accept()

    async def set_baud(self, baud: int) -> None:  # pragma: no cover - not applicable
        raise NotImplementedError

    async def write(self, data: bytes) -> None:
        assert self.server.sock is not None
        await asyncio.to_thread(self.server.sock.sendall, data)

    async def read(self, n: int, timeout_s: float) -> bytes:
        return await self.server.read(n, timeout_s)

    async def close(self) -> None:
        pass


@asynccontextmanager
async def socket_harness() -> AsyncIterator[tuple[SerialPort, SocketClient]]:
    async with loopback_server() as server:
        port = SerialPort("imu", server.url, FRAMING)
        await port.start()
        try:
            yield port, SocketClient(server)
        finally:
            port.close()


@pytest.mark.parametrize("check", conformance.SERIAL_CHECKS, ids=lambda f: f.__name__)
async def test_serial_port_on_a_null_modem(check, tmp_path: Path) -> None:
    await check(nullmodem_harness(tmp_path))


@pytest.mark.parametrize("check", conformance.SOCKET_CHECKS, ids=lambda f: f.__name__)
async def test_serial_port_on_a_socket_url(check) -> None:
    await check(socket_harness)


async def test_framing_comes_from_the_rig(tmp_path: Path) -> None:
    async with null_modem(tmp_path) as (bench_end, _):
        port = SerialPort("esc", bench_end, Framing(57600, 7, "E", 2))
        try:
            ser = port._ser
            assert (ser.baudrate, ser.bytesize, ser.parity, ser.stopbits) == (57600, 7, "E", 2)
            assert port.line is not None and (port.line.baud, port.line.bytesize, port.line.parity) == (57600, 7, "E")
        finally:
            port.close()


# -- open errors: error naming the port and the path -----------------------------------------
def test_missing_device(tmp_path: Path) -> None:
    with pytest.raises(PortOpenError) as err:
        SerialPort("imu", str(tmp_path / "ttyUSB9"), FRAMING)
    assert str(err.value) == f"port imu: {tmp_path / 'ttyUSB9'}: cannot open: no such device"
    assert isinstance(err.value, ConfigError)


async def test_busy_device(tmp_path: Path) -> None:
    async with null_modem(tmp_path) as (bench_end, _):
        first = SerialPort("imu", bench_end, FRAMING)
        try:
            with pytest.raises(PortOpenError, match=rf"^port adc: {bench_end}: cannot open: busy"):
                SerialPort("adc", bench_end, FRAMING)
        finally:
            first.close()


async def test_permission_denied(tmp_path: Path) -> None:
    if os.getuid() == 0:
        # root bypasses file modes; drop to nobody in a child to see what a user sees
        async with null_modem(tmp_path) as (bench_end, _):
            os.chmod(tmp_path, 0o755)
            code = (  # import everything first: the interpreter's files may not be readable by nobody
                "import os, sys, serial, serial.serialposix\n"
                "from hil.transport.serialport import SerialPort, Framing, PortOpenError\n"
                "os.setgid(65534); os.setuid(65534)\n"
                f"try:\n SerialPort('imu', {bench_end!r}, Framing(115200))\n"
                "except PortOpenError as e:\n print(e); sys.exit(2)\n"
            )
            proc = await asyncio.create_subprocess_exec(
                os.sys.executable, "-c", code, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
                cwd=str(Path(__file__).resolve().parents[2]),
            )
            out, err = await asyncio.wait_for(proc.communicate(), 60)
            assert proc.returncode == 2, err.decode()
            assert out.decode().startswith(f"port imu: {bench_end}: cannot open: permission denied")
    else:  # pragma: no cover - depends on who runs the tests
        pytest.skip("needs root to drop privileges")


def test_refused_socket() -> None:
    import socket

    s = socket.create_server(("127.0.0.1", 0))
    port_no = s.getsockname()[1]
    s.close()
    with pytest.raises(PortOpenError, match=rf"^port telemetry: socket://127.0.0.1:{port_no}: cannot open: connection refused"):
        SerialPort("telemetry", f"socket://127.0.0.1:{port_no}", FRAMING)


# -- low latency -------------------------------------------------------------------------------
async def test_low_latency_on_a_pty_is_reported_unsupported(tmp_path: Path) -> None:
    async with null_modem(tmp_path) as (bench_end, _):
        port = SerialPort("imu", bench_end, FRAMING)
        try:
            assert any("low-latency mode not supported by this driver" in n for n in port.notes), port.notes
        finally:
            port.close()


def test_set_low_latency_on_a_non_tty(tmp_path: Path) -> None:
    fd = os.open(tmp_path, os.O_RDONLY)
    try:
        assert set_low_latency(fd).startswith("not supported by this driver")
    finally:
        os.close(fd)


def test_ftdi_latency_timer_warning(tmp_path: Path) -> None:
    sysfs = tmp_path / "sys"
    (sysfs / "ttyUSB0").mkdir(parents=True)
    (sysfs / "ttyUSB1").mkdir(parents=True)
    (sysfs / "ttyUSB0" / "latency_timer").write_text("16\n")
    (sysfs / "ttyUSB1" / "latency_timer").write_text("1\n")
    dev = tmp_path / "dev"
    dev.mkdir()
    (dev / "ttyUSB0").touch()
    (dev / "imu-adapter").symlink_to(dev / "ttyUSB0")  # udev-style symlink: resolved
    assert usb_latency_timer_ms(str(dev / "imu-adapter"), sysfs) == 16
    note = latency_timer_note("imu", str(dev / "imu-adapter"), sysfs)
    assert note is not None and "latency timer is 16 ms (> 2 ms)" in note
    assert f"echo 1 | sudo tee {sysfs / 'ttyUSB0' / 'latency_timer'}" in note
    assert latency_timer_note("imu", str(dev / "ttyUSB1"), sysfs) is None
    assert usb_latency_timer_ms("/dev/null", sysfs) is None


def test_ioctl_numbers_are_linux_serial() -> None:
    assert (fcntl is not None) and errno.ENOTTY
    from hil.transport import serialport

    assert serialport.TIOCGSERIAL == 0x541E and serialport.TIOCSSERIAL == 0x541F
    assert serialport.ASYNC_LOW_LATENCY == 0x2000


def test_pyserial_is_real() -> None:
    assert serial.__version__


# -- rfc2217:// (no file descriptor: the reader-thread path) -------------------------------------
def rfc2217_harness(tmp_path: Path):
    from tests.transport.nullmodem import rfc2217_server

    @asynccontextmanager
    async def make() -> AsyncIterator[tuple[SerialPort, SerialClient]]:
        async with null_modem(tmp_path) as (server_end, client_end), rfc2217_server(server_end) as server:
            port = await asyncio.to_thread(SerialPort, "imu", server.url, FRAMING)
            await port.start()
            client = SerialClient(client_end)
            try:
                yield port, client
            finally:
                await client.close()
                await asyncio.to_thread(port.close)

    return make


@pytest.mark.parametrize("check", conformance.SOCKET_CHECKS, ids=lambda f: f.__name__)
async def test_serial_port_on_an_rfc2217_url(check, tmp_path: Path) -> None:
    await check(rfc2217_harness(tmp_path))


# -- the device switches its rate: the line follows after the bytes already written ----------
def _line_baud(path: str) -> int | None:
    from hil.transport.pty import _read_line_settings

    fd = os.open(path, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        return _read_line_settings(fd, opened=False).baud
    finally:
        os.close(fd)


async def test_set_baud_after_the_pending_bytes(tmp_path: Path) -> None:
    async with null_modem(tmp_path) as (bench_end, client_end):
        port = SerialPort("adc", bench_end, FRAMING)
        await port.start()
        client = SerialClient(client_end)
        try:
            await client.open(115200)
            port.write(b"Adjust your terminal\r\n")
            port.set_baud(1_000_000)
            assert await client.read(22, 2.0) == b"Adjust your terminal\r\n"
            assert _line_baud(bench_end) == 1_000_000
            assert port.line is not None and port.line.baud == 1_000_000 and port.framing.baud_bps == 1_000_000
            assert port.stats.line_changes == 1
        finally:
            await client.close()
            port.close()


async def test_set_baud_on_a_raw_socket_is_a_note() -> None:
    async with loopback_server() as server:
        port = SerialPort("adc", server.url, FRAMING)
        try:
            port.set_baud(9600)
            assert port.framing.baud_bps == 115200
            assert any("no line rate to follow" in n for n in port.notes)
        finally:
            port.close()
