"""The import paths that moved when hil/ was laid out by job keep working, with a warning."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import pytest

from hil._moved import MOVED


@pytest.mark.parametrize(("old", "new"), sorted(MOVED.items()))
def test_an_old_path_is_the_new_module_and_warns(old: str, new: str) -> None:
    module = importlib.import_module(new)
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=rf"^{old} moved to {new}; import it from there") as caught:
        assert importlib.import_module(old) is module
    # the warning points at the line that imported the old path, not at the import machinery
    assert caught[0].filename == __file__


def test_from_an_old_path_import_a_name() -> None:
    sys.modules.pop("hil.replay", None)
    with pytest.warns(DeprecationWarning, match="hil.replay moved to hil.fleet.replay"):
        from hil.replay import replay, verify  # type: ignore[import-not-found]
    from hil.fleet.replay import replay as new_replay
    from hil.fleet.replay import verify as new_verify

    assert (replay, verify) == (new_replay, new_verify)


def test_a_documented_old_import_works_in_a_fresh_interpreter() -> None:
    """What a user's script written against the old layout does: it runs, and says what moved."""
    code = ("import warnings; warnings.simplefilter('always')\n"
            "from hil.campaign import load_campaign, run_campaign\n"
            "import hil.run, hil.flight.run\n"
            "assert hil.run is hil.flight.run and callable(load_campaign) and callable(run_campaign)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "hil.campaign moved to hil.fleet.campaign" in done.stderr
    assert "hil.run moved to hil.flight.run" in done.stderr


def test_a_name_that_never_existed_is_still_not_found() -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("hil.no_such_module")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a new path never warns
        importlib.import_module("hil.fleet.campaign")
