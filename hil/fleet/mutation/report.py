"""The mutation report: score, kill matrix, survivors with their diff, equivalents, and which
mutants only a calibrated timing check could catch. Rich table, JSON, PNG heat map.

A mutant is *killed* when a scenario fails against it (a criterion, or the flight ended badly:
the flight code crashed, never booted, timed out); *survived* when every scenario it flew
passed; *equivalent* when the equivalents file gives a reason it cannot change behaviour (left
out of the score); *error* when the bench lost its task (a worker died): left out too.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from hil.fleet.campaign_case import finite

#: end reasons that are not a verdict about the flight code (the campaign stopped, a worker died)
NOT_A_VERDICT = {"cancelled", "interrupted", "worker died", "case error"}


def status(result: dict[str, Any] | None, equivalent: bool) -> str:
    if result is None:
        return "not run"
    runs = result["runs"]
    if any(not r["passed"] and r["end_reason"] not in NOT_A_VERDICT for r in runs):
        return "killed"
    if any(not r["passed"] for r in runs):
        return "error"
    return "equivalent" if equivalent else "survived"


def _kills(result: dict[str, Any] | None) -> dict[str, list[str]]:
    """scenario -> the failed criteria (or the end reason) of its first failed run."""
    out: dict[str, list[str]] = {}
    for r in (result or {}).get("runs", []):
        if not r["passed"] and r["end_reason"] not in NOT_A_VERDICT and r["scenario"] not in out:
            out[r["scenario"]] = r["failed"] or [f"flight ended: {r['end_reason']}"]
    return out


def _score(rows: list[dict[str, Any]]) -> dict[str, Any]:
    counted = [r for r in rows if r["status"] in ("killed", "survived")]
    killed = sum(r["status"] == "killed" for r in rows)
    return {"mutants": len(rows), "killed": killed, "survived": sum(r["status"] == "survived" for r in rows),
            "equivalent": sum(r["status"] == "equivalent" for r in rows),
            "errors": sum(r["status"] in ("error", "not run") for r in rows),
            "score": killed / len(counted) if counted else None}


def build(specs: list[Any], results: dict[str, dict[str, Any]], diffs: dict[str, str],
          equivalents: dict[str, str], scenarios: list[str], meta: dict[str, Any]) -> dict[str, Any]:
    """The report as one JSON-able dict (``meta``: campaign facts: suite, seeds, wall time...)."""
    rows = []
    for m in specs:
        res = results.get(m.id)
        st = status(res, m.id in equivalents)
        runs = res["runs"] if res else []
        rows.append({"id": m.id, "origin": m.origin, "layer": m.layer, "kind": m.kind, "effect": m.effect,
                     "compute_only": m.compute_only, "status": st, "kills": _kills(res),
                     "flown": [[r["scenario"], r["seed"], r["passed"], r["end_reason"]] for r in runs],
                     "wall_s": res.get("wall_s") if res else None,
                     "equivalent_reason": equivalents.get(m.id),
                     "diff": diffs.get(m.id, "") if st in ("survived", "equivalent") else None})
    by_origin = {o: _score([r for r in rows if r["origin"] == o]) for o in ("catalogue", "operator")}
    layers = sorted({r["layer"] for r in rows})
    survivors_by_layer = {lay: [r["id"] for r in rows if r["layer"] == lay and r["status"] == "survived"]
                          for lay in layers}
    return {"meta": meta, "scenarios": scenarios, "score": _score(rows), "by_origin": by_origin,
            "survivors_by_layer": {k: v for k, v in survivors_by_layer.items() if v},
            "timing_only": [{"id": r["id"], "status": r["status"]} for r in rows if r["compute_only"]],
            "mutants": rows}


def write_json(report: dict[str, Any], path: Path) -> None:
    path.write_text(json.dumps(finite(report), indent=1, allow_nan=False))


_STYLE = {"killed": "green", "survived": "bold red", "equivalent": "cyan", "error": "yellow", "not run": "dim"}


def print_report(out: Console, report: dict[str, Any]) -> None:
    t = Table(title="hil mutate: mutants", title_justify="left")
    for col in ("mutant", "layer", "kind", "status", "killed by (scenario: criterion)"):
        t.add_column(col, overflow="fold")
    for r in report["mutants"]:
        kills = "; ".join(f"{s}: {', '.join(c)}" for s, c in r["kills"].items())
        why = kills or (r["equivalent_reason"] or "")
        t.add_row(r["id"], r["layer"], r["kind"], f"[{_STYLE[r['status']]}]{r['status']}[/]", why)
    out.print(t)
    for origin, s in report["by_origin"].items():
        if s["mutants"]:
            pct = "n/a" if s["score"] is None else f"{100 * s['score']:.1f} %"
            out.print(f"{origin}: {s['killed']} killed, {s['survived']} survived, {s['equivalent']} equivalent, "
                      f"{s['errors']} errors of {s['mutants']}: score {pct}", highlight=False)
    for origin, threshold, met in report.get("targets", []):
        out.print(f"target {origin} >= {100 * threshold:.0f} %: {'met' if met else 'NOT met'}", highlight=False)
    for r in report["mutants"]:
        if r["status"] == "survived":
            out.print(f"[bold red]survivor[/] {r['id']} ({r['layer']}/{r['kind']}): {r['effect']}", highlight=False)
            out.print(r["diff"] or "", markup=False, highlight=False)
    if report["timing_only"]:
        ids = ", ".join(f"{t['id']} ({t['status']})" for t in report["timing_only"])
        out.print(f"only a calibrated timing check could catch: {ids}", highlight=False)


def plot_heatmap(report: dict[str, Any], path: Path) -> None:
    """Mutants x scenarios: killed (the scenario failed), passed, not flown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import ListedColormap

    rows, cols = report["mutants"], report["scenarios"]
    grid = np.full((len(rows), len(cols)), 0.0)  # 0 not flown, 1 passed, 2 killed
    for i, r in enumerate(rows):
        for scen, _seed, passed, _end in r["flown"]:
            if scen in cols:
                j = cols.index(scen)
                grid[i, j] = max(grid[i, j], 1.0 if passed else 2.0)
    # room below the grid for the scenario names at 60 degrees (about 0.048 in a character at
    # 7 pt), so tight_layout fits a one-mutant report too
    label_in = 0.048 * max((len(c) for c in cols), default=0)
    fig, ax = plt.subplots(figsize=(1.2 + 0.45 * len(cols), 1.0 + label_in + 0.22 * len(rows)))
    ax.imshow(grid, cmap=ListedColormap(["#f0f0f0", "#d9534f", "#2e8b57"]), vmin=0, vmax=2, aspect="auto")
    ax.set_xticks(range(len(cols)), cols, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(range(len(rows)), [f"{r['id']} [{r['status']}]" for r in rows], fontsize=6)
    ax.set_title("kill matrix: green = scenario failed (kill), red = passed, grey = not flown", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def targets(report: dict[str, Any], min_score: float, min_operator_score: float) -> list[tuple[str, float, bool]]:
    """(origin, threshold, met) for each origin that has mutants: the catalogue against
    ``min_score``, operator mutants against ``min_operator_score`` (0..1)."""
    out = []
    for origin, threshold in (("catalogue", min_score), ("operator", min_operator_score)):
        s = report["by_origin"][origin]
        if s["mutants"]:
            out.append((origin, threshold, s["score"] is not None and s["score"] >= threshold))
    return out


def exit_code(report: dict[str, Any], min_score: float, min_operator_score: float | None = None) -> int:
    """0 when every origin's score meets its threshold (see :func:`targets`), else 1."""
    t = targets(report, min_score, min_score if min_operator_score is None else min_operator_score)
    return 0 if t and all(met for _, _, met in t) else 1
