"""The edit catalogue of a flight code (TOML) and its equivalents file, validated with pydantic.

A catalogue names the source tree (``[target] tree``, relative to the catalogue's directory's
repository root given by the caller) and lists ``[[mutant]]`` entries: ``id``, ``layer``,
``kind``, ``file`` (relative to the tree), ``old`` (exact text, found exactly once),
``new``, ``effect`` (one line: what it would do to a vehicle), ``compute_only``.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from hil.config import ConfigError

#: "hal": a hardware layer of its own (the firmware's hal/: the LPC2148's peripherals)
Layer = Literal["drivers", "estimation", "control", "modes", "loop", "telemetry", "hal"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Target(_Strict):
    name: str
    tree: str = Field(description="the source tree, relative to the project root")
    operator_modules: tuple[str, ...] = ()
    #: files outside the tree that building it needs (a C tree's flight config), relative to
    #: the project root: copied beside the mutant's tree, never mutated
    context: tuple[str, ...] = ()

    @field_validator("context")
    @classmethod
    def _inside(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for rel in v:
            if Path(rel).is_absolute() or ".." in Path(rel).parts:
                raise ValueError(f"{rel!r} must be a path inside the project")
        return v


class Mutant(_Strict):
    """One named edit of a copy of the tree."""

    id: str = Field(pattern=r"^[a-z0-9][a-z0-9.-]*$")
    layer: Layer
    kind: str
    file: str
    old: str = Field(min_length=1)
    new: str
    effect: str = Field(min_length=10)
    compute_only: bool = False

    @field_validator("file")
    @classmethod
    def _relative(cls, v: str) -> str:
        if Path(v).is_absolute() or ".." in Path(v).parts:
            raise ValueError("must be a path inside the tree")
        return v


class Catalogue(_Strict):
    target: Target
    mutant: tuple[Mutant, ...]
    path: Path | None = None

    @field_validator("mutant")
    @classmethod
    def _unique(cls, v: tuple[Mutant, ...]) -> tuple[Mutant, ...]:
        seen: set[str] = set()
        for m in v:
            if m.id in seen:
                raise ValueError(f"duplicate id {m.id!r}")
            seen.add(m.id)
        return v


class Equivalent(_Strict):
    id: str
    reason: str = Field(min_length=20)


class Equivalents(_Strict):
    equivalent: tuple[Equivalent, ...] = ()


def _read(path: Path) -> dict:
    try:
        with path.open("rb") as f:
            return tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from exc


def _explain(path: Path, exc: ValidationError) -> ConfigError:
    lines = [f"{path}: {'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in exc.errors()]
    return ConfigError("\n".join(lines))


def load_catalogue(path: Path) -> Catalogue:
    """Parse and validate a catalogue; ConfigError naming file, key and reason."""
    data = _read(path)
    try:
        return Catalogue.model_validate({**data, "path": path})
    except ValidationError as exc:
        raise _explain(path, exc) from exc


def load_equivalents(path: Path | None, known: set[str] | None = None,
                     more_known: Callable[[], set[str]] | None = None) -> dict[str, str]:
    """id -> reason. ``known``: ids that exist (an equivalent of an unknown mutant is an error);
    ``more_known``: asked only when some id is not in ``known`` (the operator mutants a draw
    could give, which cost a parse of the tree to list)."""
    if path is None or not path.exists():
        return {}
    try:
        eq = Equivalents.model_validate(_read(path))
    except ValidationError as exc:
        raise _explain(path, exc) from exc
    out = {e.id: e.reason for e in eq.equivalent}
    if known is not None:
        unknown = sorted(set(out) - known)
        if unknown and more_known is not None:
            unknown = sorted(set(unknown) - more_known())
        if unknown:
            raise ConfigError(f"{path}: equivalent.id: no such mutant: {', '.join(unknown)}")
    return out
