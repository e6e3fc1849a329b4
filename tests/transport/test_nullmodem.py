"""The null-modem pty pair the real-serial-port tests stand on, with either relay.

``default`` is what :func:`null_modem` uses on this machine (socat when installed, as in CI,
so these checks also hold the tests' own relay to socat's behaviour); ``ptyrelay`` is the
tests' own relay (tests/transport/ptyrelay.py), which README's command 2 uses where socat is
missing. Every check runs on both; none needs socat.
"""

from __future__ import annotations

import asyncio
import errno
import fcntl
import os
import random
import select
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

from tests.transport.nullmodem import PTY_RELAY, null_modem, relay_command
from tests.transport.ptyrelay import RAWER

pytestmark = [pytest.mark.pty]

RELAYS = {"default": False, "ptyrelay": True}


@pytest.fixture(params=list(RELAYS))
def own_relay(request: pytest.FixtureRequest) -> bool:
    return RELAYS[request.param]


def _open(path: str) -> int:
    return os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)


def _exchange(fds: tuple[int, int], payloads: tuple[bytes, bytes], timeout_s: float = 20.0) -> tuple[bytes, bytes]:
    """Write ``payloads[i]`` into ``fds[i]`` in random-sized pieces while reading both ends;
    returns what arrived at ``(fds[1], fds[0])``."""
    rng = random.Random(7)
    todo = [memoryview(p) for p in payloads]
    got = [bytearray(), bytearray()]  # got[i]: read at the far end of fds[i]
    deadline = time.monotonic() + timeout_s
    while (len(got[0]) < len(payloads[0]) or len(got[1]) < len(payloads[1])) and time.monotonic() < deadline:
        want_w = [fd for fd, rest in zip(fds, todo, strict=True) if rest]
        readable, writable, _ = select.select(list(fds), want_w, [], 0.5)
        for i, fd in enumerate(fds):
            if fd in writable:
                n = min(len(todo[i]), rng.randint(1, 5000))
                try:
                    todo[i] = todo[i][os.write(fd, todo[i][:n]):]
                except BlockingIOError:
                    pass
            if fd in readable:
                got[1 - i] += os.read(fd, 65536)
    return bytes(got[0]), bytes(got[1])


def _read_exactly(fd: int, n: int, timeout_s: float = 10.0) -> bytes:
    got = bytearray()
    deadline = time.monotonic() + timeout_s
    while len(got) < n and time.monotonic() < deadline:
        if select.select([fd], [], [], 0.5)[0]:
            got += os.read(fd, n - len(got))
    return bytes(got)


async def test_every_byte_both_ways_at_once(tmp_path: Path, own_relay: bool) -> None:
    ab = bytes(range(256)) * 1024  # 256 KiB, every byte value, incl. ^C ^D ^S ^Q CR LF
    ba = bytes(reversed(range(256))) * 768
    async with null_modem(tmp_path, own_relay=own_relay) as (a, b):
        fa, fb = _open(a), _open(b)
        try:
            at_b, at_a = await asyncio.to_thread(_exchange, (fa, fb), (ab, ba))
        finally:
            os.close(fa)
            os.close(fb)
    assert at_b == ab
    assert at_a == ba


async def test_both_ends_start_raw_as_socat_leaves_them(tmp_path: Path, own_relay: bool) -> None:
    async with null_modem(tmp_path, own_relay=own_relay) as ends:
        for end in ends:
            fd = _open(end)
            try:
                attrs = termios.tcgetattr(fd)
            finally:
                os.close(fd)
            assert attrs[:6] == RAWER, end
            assert (attrs[6][termios.VMIN], attrs[6][termios.VTIME]) == (1, 0)


async def test_settings_stay_on_their_end_across_a_reopen(tmp_path: Path, own_relay: bool) -> None:
    """Rate and stop bits are the end's own (the kernel's); the far end keeps its own. (Linux's
    pty driver itself forces 8 data bits and no parity, whatever the relay.)"""
    async with null_modem(tmp_path, own_relay=own_relay) as (a, b):
        fa = _open(a)
        attrs = termios.tcgetattr(fa)
        attrs[2] |= termios.CSTOPB
        attrs[4] = attrs[5] = termios.B57600
        termios.tcsetattr(fa, termios.TCSANOW, attrs)
        os.close(fa)
        fa, fb = _open(a), _open(b)
        try:
            kept, far = termios.tcgetattr(fa), termios.tcgetattr(fb)
        finally:
            os.close(fa)
            os.close(fb)
    assert kept[4:6] == [termios.B57600] * 2
    assert kept[2] & termios.CSTOPB
    assert far[:6] == RAWER


async def test_the_line_outlives_a_close_of_either_end(tmp_path: Path, own_relay: bool) -> None:
    async with null_modem(tmp_path, own_relay=own_relay) as (a, b):
        fb = _open(b)
        try:
            for word in (b"one", b"two"):
                fa = _open(a)
                os.write(fa, word)
                os.close(fa)
                assert await asyncio.to_thread(_read_exactly, fb, len(word)) == word
            os.close(fb)
            fa, fb = _open(a), _open(b)
            os.write(fb, b"back")
            assert await asyncio.to_thread(_read_exactly, fa, 4) == b"back"
            os.close(fa)
        finally:
            os.close(fb)


def _fill(fd: int, limit_bytes: int) -> bytes:
    """Write into ``fd`` until it stays full for 0.5 s or ``limit_bytes`` went in."""
    rng = random.Random(3)
    sent = bytearray()
    while len(sent) < limit_bytes:
        chunk = rng.randbytes(4096)
        try:
            sent += chunk[: os.write(fd, chunk)]
        except BlockingIOError:
            if not select.select([], [fd], [], 0.5)[1]:
                break
    return bytes(sent)


async def test_an_unread_end_fills_and_holds_back_the_writer(tmp_path: Path, own_relay: bool) -> None:
    """Nobody reads ``b``: the relay buffers at most a read's worth, so the writer on ``a``
    soon meets a full line (what a bench port counts as overflow); then ``b`` gets every
    accepted byte, in order."""
    limit = 4 << 20
    async with null_modem(tmp_path, own_relay=own_relay) as (a, b):
        fa, fb = _open(a), _open(b)
        try:
            sent = await asyncio.to_thread(_fill, fa, limit)
            got = await asyncio.to_thread(_read_exactly, fb, len(sent))
        finally:
            os.close(fa)
            os.close(fb)
    assert 0 < len(sent) < 1 << 20, len(sent)  # kernel buffers + one relay read, far below 4 MiB
    assert got == sent


async def test_no_modem_lines_on_either_end(tmp_path: Path, own_relay: bool) -> None:
    """A pty has no RTS/CTS/DTR/DSR/DCD/RI; neither relay invents them."""
    async with null_modem(tmp_path, own_relay=own_relay) as ends:
        for end in ends:
            fd = _open(end)
            try:
                with pytest.raises(OSError) as err:
                    fcntl.ioctl(fd, termios.TIOCMGET, struct.pack("I", 0))
                assert err.value.errno == errno.ENOTTY
            finally:
                os.close(fd)


async def test_a_file_in_the_way_is_replaced_and_the_links_go_at_the_end(tmp_path: Path, own_relay: bool) -> None:
    (tmp_path / "line-bench").write_text("stale")
    started: list[asyncio.subprocess.Process] = []
    async with null_modem(tmp_path, own_relay=own_relay, started=started) as (a, b):
        assert os.readlink(a).startswith("/dev/pts/") and os.readlink(b).startswith("/dev/pts/")
    assert started[0].returncode == 128 + 15  # SIGTERM, as socat reports it
    assert not os.path.lexists(a) and not os.path.lexists(b)
    assert not Path(f"/proc/{started[0].pid}").exists()


async def test_the_own_relay_ends_with_its_parent(tmp_path: Path) -> None:
    """End of file on stdin (the test process died) ends the relay and removes its links."""
    started: list[asyncio.subprocess.Process] = []
    async with null_modem(tmp_path, own_relay=True, started=started) as (a, b):
        proc = started[0]
        assert proc.stdin is not None
        proc.stdin.close()
        assert await asyncio.wait_for(proc.wait(), 10) == 0
        assert not os.path.lexists(a) and not os.path.lexists(b)


def test_the_own_relay_refuses_a_wrong_call(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-I", "-S", str(PTY_RELAY), str(tmp_path / "a")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr == "usage: ptyrelay.py LINK_A LINK_B\n"


def test_socat_when_installed_else_the_own_relay(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    own = [sys.executable, "-I", "-S", str(PTY_RELAY), str(a), str(b)]
    assert relay_command(a, b, own=True) == own
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    monkeypatch.setenv("PATH", str(bin_dir))
    assert relay_command(a, b) == own
    socat = bin_dir / "socat"
    socat.write_text("#!/bin/sh\n")
    socat.chmod(0o755)
    assert relay_command(a, b) == [str(socat), "-d", "-d", f"pty,rawer,link={a}", f"pty,rawer,link={b}"]
