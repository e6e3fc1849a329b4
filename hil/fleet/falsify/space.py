"""What ``hil falsify`` may vary: a scenario's ``[falsify]`` table as a search space, and each
point of it as a standalone scenario with fixed values (docs/falsify.md).

    [[falsify.vary]]
    key = "faults.0.duration_s"   # a dotted key into this file's own tables (list index: a number)
    range = [0.1, 2.0]
    [[falsify.vary]]
    key = "scenario.seed"
    range = [1, 100000]
    integer = true

A key must name a number the file sets (a fault's time, duration or magnitude, a stick's
pulse, the wind, a payload's mass, the seed): the search varies what the scenario says, and
the written point is that scenario with those values, which ``hil run`` flies as it is.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from hil.config import ConfigError
from hil.config.files import load_toml, validate
from hil.config.scenario import Scenario, Vary, load_scenario


def _walk(data: Any, key: str) -> tuple[Any, str | int]:
    """The container holding ``key``'s last part, and that part (KeyError/IndexError if absent)."""
    parts: list[str | int] = [int(p) if p.isdigit() else p for p in key.split(".")]
    node = data
    for part in parts[:-1]:
        node = node[part]
    last = parts[-1]
    node[last]  # noqa: B018 - the lookup is the check
    return node, last


def get_value(data: dict[str, Any], key: str) -> Any:
    node, last = _walk(data, key)
    return node[last]


def set_value(data: dict[str, Any], key: str, value: float | int) -> None:
    node, last = _walk(data, key)
    node[last] = value


@dataclass(frozen=True)
class Space:
    """A scenario file and the quantities its ``[falsify]`` table lets vary."""

    path: Path
    data: dict[str, Any]  #: the file's tables as read
    scenario: Scenario
    vary: tuple[Vary, ...]

    @property
    def keys(self) -> list[str]:
        return [v.key for v in self.vary]

    def bounds(self) -> list[tuple[float, float]]:
        return [v.range for v in self.vary]

    def integrality(self) -> np.ndarray:
        return np.array([v.integer for v in self.vary], dtype=bool)

    def values(self, x: Any) -> dict[str, float | int]:
        """A point (one number per key, in ``vary`` order) as the values the file gets."""
        out: dict[str, float | int] = {}
        for v, xi in zip(self.vary, np.asarray(x, dtype=float), strict=True):
            value = min(max(float(xi), v.range[0]), v.range[1])
            out[v.key] = int(round(value)) if v.integer else value
        return out

    def fixed(self, values: dict[str, float | int], note: str) -> dict[str, Any]:
        """The scenario with ``values`` set and no ``[falsify]`` table: one flight, as a file."""
        data = copy.deepcopy(self.data)
        data.pop("falsify", None)
        for key, value in values.items():
            set_value(data, key, value)
        header = data["scenario"]
        header["description"] = f"{header.get('description', '')} [{note}]".strip()
        return data

    def write(self, values: dict[str, float | int], path: Path, note: str) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"# {note}\n# values: {values}\n" + tomli_w.dumps(self.fixed(values, note)))
        return path


def load_space(path: Path) -> Space:
    """The search space of scenario file ``path``: ConfigError (file, key, reason) when it has
    no ``[falsify]``, a key names no number the file sets, or a range's end makes the
    scenario invalid."""
    scenario = load_scenario(path)
    if scenario.falsify is None:
        raise ConfigError(f"{path}: [falsify]: missing: the scenario says nothing may vary "
                          "(add [[falsify.vary]] tables with key and range; docs/falsify.md)")
    data = load_toml(path)
    for i, v in enumerate(scenario.falsify.vary):
        where = f"{path}: [falsify] vary.{i}.key"
        if v.key.split(".", 1)[0] in ("falsify", "criteria"):
            raise ConfigError(f"{where}: {v.key!r}: the search varies the flight, not its criteria")
        try:
            current = get_value(data, v.key)
        except (KeyError, IndexError, TypeError):
            raise ConfigError(f"{where}: {v.key!r} is not set in the file (give the value it has when not "
                              "searched)") from None
        if isinstance(current, bool) or not isinstance(current, (int, float)) or not math.isfinite(current):
            raise ConfigError(f"{where}: {v.key!r} is {current!r}, not a number")
        if v.integer and not isinstance(current, int):
            raise ConfigError(f"{where}: {v.key!r} is {current!r}: integer = true needs a whole number there")
    space = Space(path, data, scenario, tuple(scenario.falsify.vary))
    for i, v in enumerate(space.vary):
        for end in v.range:
            values = space.values([end if w is v else get_value(data, w.key) for w in space.vary])
            try:
                validate(Scenario, space.fixed(values, "check"), file=path, section="")
            except ConfigError as exc:
                raise ConfigError(f"{path}: [falsify] vary.{i}.range: {v.key} = {values[v.key]} makes the "
                                  f"scenario invalid: {exc}") from None
    return space


__all__ = ["Space", "get_value", "load_space", "set_value"]
