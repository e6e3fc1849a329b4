"""Loader of the golden Xbus vectors in tests/golden/xsens/xsens_vectors.json (sources inside)."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

VECTORS_PATH = Path(__file__).resolve().parents[2] / "golden" / "xsens" / "xsens_vectors.json"


@cache
def vectors() -> dict[str, Any]:
    return json.loads(VECTORS_PATH.read_text())


def hexb(text: str) -> bytes:
    return bytes.fromhex(text)


def frame(name: str) -> dict[str, Any]:
    for f in vectors()["frames"]:
        if f["name"] == name:
            return f
    raise KeyError(name)
