"""Every default of the firmware's config (firmware/src/config.c ``cfg_defaults``) equals the
Python flight code's (flightcode/config_tables.py): a key a config file leaves out flies the
same value in both flight codes. The C defaults are written by hand; this walks the firmware's
own key table (config_keys.c: each dotted key, its kind and its offset in ``fc_config_t``), reads
the value at that offset and compares it with the Python config parsed from a file holding only
the ports, so a key added to one side without the other, or a default changed on one side, fails
here naming the key."""

from __future__ import annotations

import ctypes as C
import dataclasses
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from flightcode.config import FlightConfig, parse
from flightcode.log import Level

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "firmware"))
import gen  # noqa: E402
import hostlib  # noqa: E402

HERE = Path(__file__).resolve().parent
#: cfg_kind_t (firmware/src/config_keys.h)
FLOAT, INT, BOOL, PATH, ENUM, INT_ENUM, INT3, MOUNT, BOOL_ENUM = range(9)
PORTS_ONLY = "".join(f'[ports.{p}]\npath = "/dev/{p}"\nbaud = 115200\n\n' for p in ("imu", "adc", "rc", "esc", "telemetry"))


class KeyT(C.Structure):
    _fields_ = [("key", C.c_char_p), ("kind", C.c_int), ("offset", C.c_size_t), ("choices", C.c_char_p)]


@pytest.fixture(scope="module")
def c_defaults(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, list[KeyT]]:
    """``cfg_defaults``' struct as bytes, and the key table."""
    out = tmp_path_factory.mktemp("cfg")
    gen.generate(ROOT / "rigs" / "firmware-paper-quad.toml", out / "gen")
    src = hostlib.SRC
    sources = [src / "config.c", src / "config_keys.c", src / "toml_lite.c", src / "log.c", src / "drivers" / "analog.c",
               src / "drivers" / "buspirate.c", HERE / "log_stub.c", HERE / "config_shim.c"]
    lib = C.CDLL(str(hostlib.build_shared(sources, out, "cfgdefaults", include_dirs=(out / "gen", src, src.parent / "include"))))
    lib.cfg_test_sizeof.restype = C.c_size_t
    lib.cfg_test_keys.restype = C.POINTER(KeyT)
    n = C.c_size_t.in_dll(lib, "cfg_n_keys").value
    buf = C.create_string_buffer(lib.cfg_test_sizeof())
    lib.cfg_defaults(buf)
    keys = lib.cfg_test_keys()
    return buf.raw, [keys[i] for i in range(n)]


def python_value(cfg: FlightConfig, dotted: str) -> Any:
    value: Any = cfg
    for part in dotted.split("."):
        value = getattr(value, part)
    return value


def c_value(raw: bytes, k: KeyT) -> Any:
    at, choices = k.offset, (k.choices or b"").decode().split("|")
    if k.kind == FLOAT:
        return float(np.frombuffer(raw, np.float32, 1, at)[0])
    if k.kind in (INT, INT_ENUM):
        return int(np.frombuffer(raw, np.int64, 1, at)[0])
    if k.kind == BOOL:
        return bool(raw[at])
    if k.kind == PATH:
        return raw[at:].split(b"\0", 1)[0].decode()
    if k.kind == ENUM:
        index = int(np.frombuffer(raw, np.intc, 1, at)[0])
        return index if k.key == b"log.level" else choices[index]
    if k.kind == BOOL_ENUM:
        return choices[int(bool(raw[at]))]
    if k.kind == INT3:
        return tuple(int(v) for v in np.frombuffer(raw, np.int64, 3, at))
    if k.kind == MOUNT:
        return tuple(raw[at + 4 * i : at + 4 * i + 4].split(b"\0", 1)[0].decode() for i in range(3))
    raise AssertionError(f"{k.key!r}: kind {k.kind} unknown to this test")


def expected(py: Any, k: KeyT) -> Any:
    """The Python default in the form the C field holds it."""
    if k.kind == FLOAT:
        return float(np.float32(py))
    if k.key == b"log.level":  # a name in the file, its severity (10, 20, ...) in the struct
        return int(Level[py.upper()]) if isinstance(py, str) else int(py)
    if hasattr(py, "value") and not isinstance(py, (int, float)):  # a str Enum
        return py.value
    if isinstance(py, (list, tuple)):
        return tuple(py)
    return py


def test_every_c_default_is_the_python_default(c_defaults: tuple[bytes, list[KeyT]]) -> None:
    raw, keys = c_defaults
    cfg = parse(PORTS_ONLY)
    checked, wrong = 0, []
    for k in keys:
        key = k.key.decode()
        if key.startswith("ports.") or key == "adc.bridge":  # from the file / one choice, nothing stored
            continue
        want, got = expected(python_value(cfg, key), k), c_value(raw, k)
        checked += 1
        if got != want:
            wrong.append(f"{key}: C {got!r}, Python {want!r}")
    assert not wrong, "the firmware's defaults differ from flightcode's:\n" + "\n".join(wrong)
    assert checked > 100  # the whole table, not a few rows


def _leaves(obj: Any, prefix: str = "") -> list[str]:
    out: list[str] = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        out += _leaves(value, f"{prefix}{f.name}.") if dataclasses.is_dataclass(value) else [prefix + f.name]
    return out


def test_both_flight_codes_have_the_same_keys(c_defaults: tuple[bytes, list[KeyT]]) -> None:
    _, keys = c_defaults
    c_keys = {k.key.decode() for k in keys}
    py_keys = set(_leaves(parse(PORTS_ONLY)))
    assert not py_keys - c_keys, f"keys flightcode reads and the firmware does not: {sorted(py_keys - c_keys)}"
    assert not c_keys - py_keys, f"keys the firmware reads and flightcode does not: {sorted(c_keys - py_keys)}"
