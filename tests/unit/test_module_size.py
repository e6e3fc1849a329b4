"""No module of the product is over 400 lines: a module that long holds a second job to split
out (docs/architecture.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("hil", "emulators", "flightcode")
MAX_LINES = 400


def long_modules(root: Path, packages: tuple[str, ...] = PACKAGES, limit: int = MAX_LINES) -> list[tuple[str, int]]:
    """(path relative to ``root``, line count) of every ``.py`` module over ``limit`` lines."""
    found = []
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            n = len(path.read_text().splitlines())
            if n > limit:
                found.append((path.relative_to(root).as_posix(), n))
    return found


def test_no_module_is_over_400_lines() -> None:
    assert not long_modules(ROOT), f"modules over {MAX_LINES} lines (split out their second job): {long_modules(ROOT)}"


@pytest.mark.parametrize("lines, expected", [(400, []), (401, [("hil/big.py", 401)])])
def test_the_check_finds_a_long_module(tmp_path: Path, lines: int, expected: list[tuple[str, int]]) -> None:
    (tmp_path / "hil").mkdir()
    (tmp_path / "hil" / "big.py").write_text("x = 1\n" * lines)
    assert long_modules(tmp_path) == expected
