"""Payloads -> bytes and strings for the MCAP file: JSON encoding (numpy values, non-finite
floats written as null and counted), one tick's ADC conversions as one message, and the
str -> str dicts of metadata records. Pure functions, run on the recorder's writer side."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import orjson


def json_default(o: Any) -> Any:
    """JSON value of what ``json``/``orjson`` cannot encode themselves (numpy arrays and
    scalars, tuples, sets); raises TypeError for anything else."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (tuple, set, frozenset)):
        return list(o)
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def sanitise(o: Any) -> tuple[Any, int]:
    """Replace non-finite floats by None (JSON has no NaN); returns (value, how many)."""
    if isinstance(o, float):
        return (o, 0) if math.isfinite(o) else (None, 1)
    if isinstance(o, dict):
        n = 0
        out: dict[str, Any] = {}
        for k, v in o.items():
            out[k], m = sanitise(v)
            n += m
        return out, n
    if isinstance(o, (list, tuple)):
        items = [sanitise(v) for v in o]
        return [v for v, _ in items], sum(m for _, m in items)
    if isinstance(o, (np.ndarray, np.generic)):
        return sanitise(json_default(o))
    return o, 0


def encode_json(payload: Mapping[str, Any]) -> tuple[bytes, int]:
    """Compact UTF-8 JSON of ``payload`` and how many non-finite floats became null."""
    # orjson is ~10x faster than json here (it runs for every message on the writer
    # thread, which shares the GIL with the tick). It writes NaN/inf as null silently, so
    # output with a null goes the exact (slow) way to count the non-finite values.
    try:
        data = orjson.dumps(payload, default=json_default, option=orjson.OPT_SERIALIZE_NUMPY)
    except TypeError:
        data = b"null"
    if b"null" not in data:
        return data, 0
    try:
        return json.dumps(payload, separators=(",", ":"), allow_nan=False, default=json_default).encode(), 0
    except ValueError:  # NaN or inf somewhere
        clean, n = sanitise(payload)
        return json.dumps(clean, separators=(",", ":"), allow_nan=False, default=json_default).encode(), n


def adc_tick(conversions: list[Mapping[str, Any]]) -> dict[str, Any]:
    """``hil.AdcConversions`` fields from single-conversion payloads (``hil.AdcConversion``)."""
    first = conversions[0]
    t0 = int(first.get("t_ns", 0))
    out: dict[str, Any] = {"t_ns": t0} if "t_ns" in first else {}
    out |= {"channel": [int(c["channel"]) for c in conversions], "code": [int(c["code"]) for c in conversions],
            "volts": [float(c["volts"]) for c in conversions]}
    if any("t_ns" in c and int(c["t_ns"]) != t0 for c in conversions):
        out["dt_ns"] = [int(c.get("t_ns", t0)) - t0 for c in conversions]
    for key in ("single_ended", "vref_V"):
        if all(key in c for c in conversions):
            out[key] = [c[key] for c in conversions]
    if "port" in first:
        out["port"] = first["port"]
    return out


def str_dict(d: Mapping[str, Any], what: str, *, strict: bool) -> dict[str, str]:
    """``d`` as a metadata record's str -> str map; ``strict``: anything but str raises
    TypeError naming ``what``, else values are converted with ``str()``."""
    out: dict[str, str] = {}
    for k, v in d.items():
        if strict and not (isinstance(k, str) and isinstance(v, str)):
            raise TypeError(f"{what}: keys and values must be str, got {k!r}: {v!r}")
        out[str(k)] = v if isinstance(v, str) else str(v)
    return out
