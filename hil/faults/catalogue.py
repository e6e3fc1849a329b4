"""The catalogue: every fault kind by name, and its listing for ``hil faults``."""

from __future__ import annotations

from enum import Enum
from typing import Any

from hil.faults import adc, analog, esc, imu, link, plant, process, rc, wire, xsens
from hil.faults.base import Fault

#: kind name -> class, grouped by layer in listing order.
CATALOGUE: dict[str, type[Fault[Any]]] = {
    cls.kind: cls
    for cls in (
        *plant.FAULTS, *imu.FAULTS, *analog.FAULTS, *adc.FAULTS, *wire.FAULTS,
        *xsens.FAULTS, *rc.FAULTS, *esc.FAULTS, *link.FAULTS, *process.FAULTS,
    )
}


def _default_text(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, Enum):
        return str(value.value)
    if isinstance(value, tuple):
        return "(" + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value) + ")"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def catalogue_table() -> list[dict[str, Any]]:
    """One row per kind: kind, layer, timing, params (name, type, unit, default, required,
    description) and the description."""
    return [cls.describe() for cls in CATALOGUE.values()]


def params_text(row: dict[str, Any]) -> str:
    """The params of a catalogue row as short lines: ``name [unit] = default``."""
    lines = []
    for p in row["params"]:
        unit = f" [{p['unit']}]" if p["unit"] else ""
        default = "required" if p["required"] else f"= {_default_text(p['default'])}"
        lines.append(f"{p['name']}{unit} {default}")
    return "\n".join(lines) or "-"


_DURATION = {"span": "optional (none: to the end)", "bounded": "required", "instant": "not allowed (one action)"}


def print_catalogue(console: Any, layer: str | None = None) -> None:
    """Print the catalogue as a rich table (optionally one layer)."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape("Fault catalogue ([[faults]] kind = ..., t_s = ..., duration_s = ..., params)"))
    table.add_column("kind", no_wrap=True)
    table.add_column("layer")
    table.add_column("duration_s")
    table.add_column("params")
    table.add_column("description")
    for row in catalogue_table():
        if layer is not None and row["layer"] != layer:
            continue
        cells = (row["kind"], row["layer"], _DURATION[row["timing"]], params_text(row), row["description"])
        table.add_row(*(escape(c) for c in cells))
    console.print(table)
