"""The firmware's MCP3204 driver (firmware/src/drivers/mcp3204.c) through ctypes, against the
Python flight code's (flightcode/drivers/mcp3204.py) on the same bytes: the 4-byte request,
the code, and the LSB-first repeat (DS21298E section 5.0) that catches a bit flipped on the
line; a null bit re-applies the SPI setup, a repeat that disagrees does not."""

from __future__ import annotations

import ctypes as C
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from flightcode.drivers import mcp3204 as py

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "firmware"))
import hostlib  # noqa: E402

FRAME = 4
CHANNELS = 4


class Counters(C.Structure):
    _fields_ = [("reads", C.c_uint32), ("failed_reads", C.c_uint32), ("null_bit_errors", C.c_uint32),
                ("repeat_errors", C.c_uint32), ("no_transfer", C.c_uint32)]


class Mcp3204T(C.Structure):
    _fields_ = [("channels", C.c_uint8 * CHANNELS), ("mosi", C.c_uint8 * (FRAME * CHANNELS)),
                ("lengths", C.c_uint8 * CHANNELS), ("counters", Counters)]


@pytest.fixture(scope="module")
def lib(tmp_path_factory: pytest.TempPathFactory) -> C.CDLL:
    src = hostlib.SRC
    path = hostlib.build_shared([src / "drivers" / "mcp3204.c", Path(__file__).with_name("spi_stub.c")],
                                tmp_path_factory.mktemp("mcp3204"), "mcp3204", include_dirs=(src, src.parent / "include"))
    lib = C.CDLL(str(path))
    lib.mcp3204_decode.restype = C.c_int
    lib.mcp3204_repeat_agrees.restype = C.c_bool
    lib.mcp3204_repeat_agrees.argtypes = [C.c_char_p, C.c_int]
    lib.mcp3204_read.argtypes = [C.POINTER(Mcp3204T), C.c_uint64, C.POINTER(C.c_uint16)]
    return lib


def frame(code: int) -> bytes:
    """The MISO bytes the MCP3204 sends for ``code``: 7 hi-Z bits, the null bit, B11..B0,
    B1..B11, a zero (as the bench's model sends them, tests/unit/flightcode)."""
    bits = [0] * 8 + [(code >> (11 - i)) & 1 for i in range(12)] + [(code >> i) & 1 for i in range(1, 12)]
    bits += [0] * (8 * FRAME - len(bits))
    return bytes(int("".join(map(str, bits[8 * k : 8 * k + 8])), 2) for k in range(FRAME))


def test_the_request_is_the_python_flight_codes(lib: C.CDLL) -> None:
    for ch in range(4):
        out = (C.c_uint8 * FRAME)()
        lib.mcp3204_request(C.c_uint8(ch), out)
        assert bytes(out) == py.request(ch)


@given(code=st.integers(0, 4095), bit=st.integers(0, 8 * FRAME - 1))
def test_decode_and_repeat_agree_with_the_python_flight_code(lib: C.CDLL, code: int, bit: int) -> None:
    for miso in (frame(code), bytes(b ^ (0x80 >> (bit % 8) if i == bit // 8 else 0) for i, b in enumerate(frame(code)))):
        c_code = lib.mcp3204_decode(miso)
        py_code = py.decode(miso)
        assert c_code == (-1 if py_code is None else py_code)
        if py_code is not None:
            assert lib.mcp3204_repeat_agrees(miso, py_code) == py.repeat_agrees(miso, py_code)
    assert lib.mcp3204_repeat_agrees(frame(code), code)


def _reader(lib: C.CDLL, replies: list[bytes]) -> tuple[Mcp3204T, list[int] | None]:
    m = Mcp3204T()
    lib.mcp3204_init(C.byref(m), (C.c_uint8 * CHANNELS)(0, 1, 2, 3))
    C.memmove(C.addressof(C.c_uint8.in_dll(lib, "spi_stub_reply")), b"".join(replies), FRAME * CHANNELS)
    codes = (C.c_uint16 * CHANNELS)()
    got = lib.mcp3204_read(C.byref(m), 0, codes)
    return m, list(codes) if got == 1 else None


def test_a_repeat_that_disagrees_is_no_reading_and_no_resync(lib: C.CDLL) -> None:
    resyncs = C.c_int.in_dll(lib, "spi_stub_resyncs")
    good = [frame(c) for c in (1830, 2420, 2048, 1392)]
    m, codes = _reader(lib, good)
    assert codes == [1830, 2420, 2048, 1392] and m.counters.reads == 1
    sent = bytes((C.c_uint8 * 16).in_dll(lib, "spi_stub_sent"))
    assert sent == b"".join(py.request(ch) for ch in range(4))  # 4 bytes a channel
    flipped = bytearray(good[0])
    flipped[1] ^= 0x10  # B8 flipped on MISO: 1830 reads 1574, a plausible code
    before = resyncs.value
    m, codes = _reader(lib, [bytes(flipped), *good[1:]])
    assert codes is None and m.counters.repeat_errors == 1 and m.counters.failed_reads == 1
    assert resyncs.value == before  # a bit error, not the framing
    null = bytearray(good[2])
    null[0] |= 0x01
    m, codes = _reader(lib, [good[0], good[1], bytes(null), good[3]])
    assert codes is None and m.counters.null_bit_errors == 1 and resyncs.value == before + 1
