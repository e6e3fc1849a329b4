"""The firmware's log formats floats as flightcode's log does (Python's format(v, ".6g"), the
same as C's "%.6g") without printf's float path, which on the ARM7 costs about 0.1 ms a value
(firmware/src/log.c, log_format_g6)."""

from __future__ import annotations

import ctypes as C
import math
from pathlib import Path

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tests.unit.firmware.fwcodecs import FIRMWARE, hostlib

HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def fmt(tmp_path_factory: pytest.TempPathFactory):
    path = hostlib.build_shared([FIRMWARE / "src" / "log.c", HERE / "log_stub.c"], tmp_path_factory.mktemp("log"),
                                "log", include_dirs=(FIRMWARE / "include",))
    dll = C.CDLL(str(path))
    dll.log_format_g6.argtypes = [C.c_double, C.c_char_p, C.c_size_t]

    def g6(v: float) -> str:
        out = C.create_string_buffer(32)
        dll.log_format_g6(v, out, len(out))
        return out.value.decode()

    return g6


@settings(max_examples=3000, deadline=None)
@given(st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.floats(-1e7, 1e7, width=32),
                 st.integers(-10**9, 10**9).map(float)))
@example(0.0)
@example(-0.0)
@example(8.828125)
@example(999999.5)
@example(9.999995)
@example(1e-4)
@example(1e6)
@example(0.000123456)
@example(1e-300)
@example(1e300)
def test_six_significant_digits_as_python(fmt, v: float) -> None:
    assert fmt(v) == format(v, ".6g")


def test_non_finite(fmt) -> None:
    assert (fmt(math.nan), fmt(math.inf), fmt(-math.inf)) == ("nan", "inf", "-inf")
