"""Rig and scenario files: TOML -> validated, frozen models.

Every table of a rig file maps onto one component's frozen parameter dataclass (defined
next to the component, units in the field names); pydantic validates the table straight
into it and rejects unknown keys. Errors name the file, the key path and the reason:

    rigs/paper-quad.toml: [imu] baud_bps: Input should be a valid integer (got 'fast')
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")

ROOT = Path(__file__).resolve().parents[2]
RIGS_DIR = ROOT / "rigs"
SCENARIOS_DIR = RIGS_DIR / "scenarios"
DEFAULT_RIG = RIGS_DIR / "paper-quad.toml"


class ConfigError(Exception):
    """A rig or scenario file is wrong; the message names file, key and reason."""


def load_toml(path: Path) -> dict[str, Any]:
    """Read a TOML file, turning I/O and syntax errors into :class:`ConfigError`."""
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None


def _loc(section: str, loc: tuple[Any, ...]) -> str:
    parts = [str(p) for p in loc if p not in ("function-after", "function-before")]
    key = ".".join(parts)
    where = f"[{section}]" if section else ""
    return f"{where} {key}".strip() if key else where or "(top level)"


def validate(cls: type[T], data: Mapping[str, Any], *, file: Path | str, section: str) -> T:
    """Validate one TOML table into ``cls`` (a dataclass or pydantic model).

    Raises :class:`ConfigError` listing every problem as ``file: [section] key: reason``.
    """
    import pydantic  # here, not at the top: finding a file must not cost pydantic's import

    try:
        return pydantic.TypeAdapter(cls).validate_python(dict(data))
    except pydantic.ValidationError as exc:
        lines = []
        for err in exc.errors():
            got = err.get("input")
            shown = "" if isinstance(got, Mapping) else f" (got {got!r})"
            lines.append(f"{file}: {_loc(section, tuple(err['loc']))}: {err['msg']}{shown}")
        raise ConfigError("\n".join(lines)) from None


def check_keys(data: Mapping[str, Any], allowed: set[str], *, file: Path | str, section: str) -> None:
    """Reject keys of a table that no component knows."""
    unknown = sorted(set(data) - allowed)
    if unknown:
        known = ", ".join(sorted(allowed))
        raise ConfigError(
            "\n".join(f"{file}: [{section}] {key}: unknown key (known: {known})" for key in unknown)
        )


def resolve_rig(name_or_path: str | Path | None) -> Path:
    """A rig given by path, or by name under ``rigs/`` (``paper-quad``)."""
    if name_or_path is None:
        return DEFAULT_RIG
    path = Path(name_or_path)
    if path.exists():
        return path
    candidate = RIGS_DIR / f"{name_or_path}.toml"
    if candidate.exists():
        return candidate
    raise ConfigError(f"{name_or_path}: no such rig file (looked in {RIGS_DIR})")


def resolve_scenario(name_or_path: str | Path, rig_file: Path | None = None) -> Path:
    """A scenario given by path, or by name under ``rigs/scenarios/``."""
    path = Path(name_or_path)
    if path.exists():
        return path
    dirs = [SCENARIOS_DIR]
    if rig_file is not None:
        dirs.insert(0, rig_file.parent / "scenarios")
    for d in dirs:
        candidate = d / f"{name_or_path}.toml"
        if candidate.exists():
            return candidate
    names = sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml"))
    raise ConfigError(f"{name_or_path}: no such scenario (known: {', '.join(names)})")
