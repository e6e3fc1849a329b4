"""hil.native tells which way the device models and the plant run on this install."""

from __future__ import annotations

from pathlib import Path

import emulators.base
import hil.flight.devices
import hil.plant.plant
from hil import native


def test_compiled_matches_the_modules_files() -> None:
    state = native.compiled()
    assert state == {"emulators": not emulators.base.__file__.endswith(".py"),
                     "hil.plant": not str(hil.plant.plant.__file__).endswith(".py"),
                     "hil tick path": not str(hil.flight.devices.__file__).endswith(".py")}


def test_describe_names_the_state() -> None:
    text = native.describe()
    state = native.compiled()
    if all(state.values()):
        assert text == "compiled (mypyc)"
    elif not any(state.values()):
        assert text.startswith("interpreted")
    else:
        assert "compiled" in text and "interpreted" in text


def test_a_source_edited_after_the_build_is_reported() -> None:
    if not all(native.compiled().values()):
        assert native.built_at() is None or native.stale() == []
        return
    assert native.stale() == []  # this suite runs on a fresh build (tests/conftest.py)
    source = Path(emulators.base.__file__).with_name("base.py")
    # as if the build were older than this source
    reported = native.stale(built=source.stat().st_mtime - 1)
    assert source in reported
    assert all(p.suffix == ".py" and any(p.parent.glob(f"{p.stem}.*.so")) for p in reported)
    assert not any(p.name == "params.py" for p in reported)  # interpreted on purpose: never stale
    text = native.stale_message(reported)
    assert "pip install -e ." in text and str(reported[0]) in text
