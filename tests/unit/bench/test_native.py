"""hil.native tells which way the device models and the plant run on this install."""

from __future__ import annotations

import emulators.base
import hil.plant.plant
from hil import native


def test_compiled_matches_the_modules_files() -> None:
    state = native.compiled()
    assert state == {"emulators": not emulators.base.__file__.endswith(".py"),
                     "hil.plant": not str(hil.plant.plant.__file__).endswith(".py")}


def test_describe_names_the_state() -> None:
    text = native.describe()
    state = native.compiled()
    if all(state.values()):
        assert text == "compiled (mypyc)"
    elif not any(state.values()):
        assert text.startswith("interpreted")
    else:
        assert "compiled" in text and "interpreted" in text
