"""What ``hil falsify`` leaves: the table of flights explored (``margins.csv``), a PNG of the
search's progress (``progress.png``), the counterexample as a scenario ``hil run`` flies
(``counterexample.toml``) and ``search.json``."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

from hil.fleet.falsify.objective import FAILED
from hil.fleet.falsify.search import Flight, Search


def write_table(search: Search, keys: list[str], path: Path) -> Path:
    """One row per flight: index, generation, the values, the objective and its criterion."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["flight", "generation", *keys, "lowest_scaled_margin", "criterion", "end_reason", "scenario",
                    "log"])
        for fl in search.flights:
            w.writerow([fl.index, fl.generation, *(fl.values[k] for k in keys), f"{fl.objective:.6g}", fl.worst,
                        fl.end_reason, fl.scenario_file.name, fl.log or ""])
    return path


def plot_progress(search: Search, title: str, path: Path) -> Path:
    """Each flight's lowest scaled margin and the best so far, against flights flown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = [f.index for f in search.flights]
    measured = [f.objective for f in search.flights if f.objective > FAILED]
    floor = 1.1 * min([-1.0, *measured])
    ys = [max(f.objective, floor) for f in search.flights]  # a failure without a margin drawn at the floor
    best, running = [], float("inf")
    for y in ys:
        running = min(running, y)
        best.append(running)
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=100)
    ax.scatter(xs, ys, s=14, c=["tab:red" if f.objective < 0 else "tab:blue" for f in search.flights],
               label="a flight (red: failed)")
    ax.step(xs, best, where="post", color="black", label="lowest so far")
    ax.axhline(0.0, color="tab:red", lw=0.8, ls="--")
    ax.set_xlabel("flight")
    ax.set_ylabel("lowest margin / criterion scale")
    ax.set_title(title)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_outputs(search: Search, keys: list[str], out: Path, title: str, *, mutant: str | None = None,
                  reference: Flight | None = None, focus: list[str] | None = None) -> dict[str, str]:
    """Every output file; their paths by role. ``mutant``: the catalogue id searched;
    ``reference``: the counterexample's point flown on the unmodified flight code; ``focus``:
    the criteria the search was aimed at (None: all)."""
    files = {"table": str(write_table(search, keys, out / "margins.csv"))}
    if search.flights:
        files["progress"] = str(plot_progress(search, title, out / "progress.png"))
    cx = search.counterexample
    if cx is not None:
        files["counterexample"] = str(shutil.copyfile(cx.scenario_file, out / "counterexample.toml"))
        if cx.log:
            files["counterexample_log"] = cx.log
    best = search.best
    summary = {
        "flights": len(search.flights), "stopped": search.stopped, "wall_s": search.wall_s,
        "best": None if best is None else _flight(best), "counterexample": None if cx is None else _flight(cx),
        "files": files, "mutant": mutant, "criteria": focus,
        "reference": None if reference is None else {**_flight(reference), "separates": reference.objective >= 0},
    }
    (out / "search.json").write_text(json.dumps(summary, indent=1))
    return files


def _flight(f: Flight) -> dict[str, object]:
    return {"flight": f.index, "values": f.values, "lowest_scaled_margin": f.objective if f.objective > FAILED
            else None, "criterion": f.worst, "end_reason": f.end_reason, "scenario": str(f.scenario_file),
            "log": f.log}


__all__ = ["plot_progress", "write_outputs", "write_table"]
