"""docs/fidelity.md is what ``hil fidelity`` writes, untouched by hand.

The per-seed values in the file are read back and handed to the generator's own writer
(``hil.fleet.fidelity.write_report``); the result must be the file, byte for byte: the table's
medians and ranges, its text and its notes are then the generator's. Whether the per-seed
values are still what the flight gives is checked by flying one of them again
(tests/system/test_fidelity_doc.py).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hil.fleet import fidelity
from hil.fleet.fidelity import PAYLOAD_ROW, ROWS, Cell, TwinDetail, write_report

ROOT = Path(__file__).resolve().parents[3]
DOC = ROOT / "docs" / "fidelity.md"


def parse_seed_values(text: str) -> dict[int, list[str]]:
    """``{seed: [value text per row, in table order, the payload row last]}``."""
    rows = re.findall(r"^\* seed (\d+): ((?:[^,/\n]+, )+[^,/\n]+)$", text, flags=re.M)
    return {int(seed): values.split(", ") for seed, values in rows}


def regenerate(text: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """The file ``hil fidelity`` writes for the per-seed values, verdicts, twins and plots in ``text``."""
    seeds = [int(s) for s in re.search(r"seeds ([\d, ]+), lockstep", text).group(1).split(", ")]  # type: ignore[union-attr]
    per_seed = parse_seed_values(text)
    verdicts = re.findall(r"^\|[^\n]*\| (PASS|FAIL) \|$", text, flags=re.M)
    assert len(verdicts) == len(ROWS) + 1, "docs/fidelity.md: one table row per fidelity row and the payload row"
    cells = {}
    for i in range(len(ROWS) + 1):
        values = [float(per_seed[s][i]) for s in seeds if s in per_seed]
        cells[i] = Cell(values=values, passes=[verdicts[i] == "PASS"] * max(1, len(values)))
    payload = cells.pop(len(ROWS))
    twins = [TwinDetail(int(s), float(a), float(b), float(r)) for s, a, b, r in re.findall(
        r"^\* seed (\d+): ([\d.]+) / ([\d.]+) deg, rotor speed x([\d.]+)$", text, flags=re.M)]
    plots = re.findall(r"^!\[([^\]]+)\]\(fidelity/", text, flags=re.M)
    retries = re.search(r"flown again: (.*)$", text, flags=re.M)
    monkeypatch.setattr(fidelity, "RETRIES", retries.group(1).split("; ") if retries else [])
    return write_report(seeds, cells, payload, plots, tmp_path / "fidelity.md", twins or None)


def test_fidelity_doc_is_the_generators_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = DOC.read_text()
    assert regenerate(text, tmp_path, monkeypatch) == text, (
        "docs/fidelity.md differs from what `hil fidelity` writes for its own per-seed values: "
        "regenerate it with `hil fidelity --seeds 5`, do not edit it")


def test_plots_named_in_the_doc_exist() -> None:
    plots = re.findall(r"\]\((fidelity/[^)]+)\)", DOC.read_text())
    assert plots and all((DOC.parent / p).is_file() for p in plots)


def test_a_hand_edited_figure_is_caught(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = DOC.read_text()
    first_row = next(line for line in text.splitlines() if line.startswith(f"| {ROWS[0].figure} |"))
    cell = first_row.split(" | ")[2]
    edited = text.replace(first_row, first_row.replace(cell, "0.5 (0.4 - 0.6) deg"))
    assert edited != text
    assert regenerate(edited, tmp_path, monkeypatch) != edited


def test_every_row_has_a_value_per_seed() -> None:
    per_seed = parse_seed_values(DOC.read_text())
    assert per_seed and all(len(v) == len(ROWS) + 1 for v in per_seed.values())
    assert PAYLOAD_ROW[0] in DOC.read_text()
