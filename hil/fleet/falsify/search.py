"""The search of ``hil falsify``: differential evolution (SciPy's ``differential_evolution``)
over a scenario's ``[falsify]`` space, minimising the flight's lowest scaled margin
(hil/fleet/falsify/objective.py), each generation flown in parallel on the campaign engine
(Dask or the process pool, the rig and the point's scenario shipped as bytes: no shared
filesystem needed).

Deterministic per point: a point is a scenario file with fixed values, seed included, flown in
lockstep; the optimiser's own draws come from ``seed``. The search stops at the end of the
first generation with a failing flight (the most negative one is the counterexample), or when
the next generation would pass the flight budget or the wall-time budget has run out. A
population that converged starts again from new draws (a restart) while the budget lasts.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hil import clock
from hil.config.scenario import Criterion
from hil.fleet.campaign_bundle import Files, land_result, rig_files, scenario_files
from hil.fleet.campaign_executors import run_dask, run_pool
from hil.fleet.campaign_worker import run_bundled_case
from hil.fleet.falsify.objective import robustness
from hil.fleet.falsify.space import Space


@dataclass(frozen=True)
class Flight:
    """One point flown."""

    index: int
    generation: int
    values: dict[str, float | int]
    objective: float  #: lowest scaled margin (< 0: a criterion failed)
    worst: str  #: the criterion that set it
    end_reason: str
    scenario_file: Path
    log: str | None  #: its MCAP (kept for failing flights)
    wall_s: float


@dataclass
class Search:
    """Everything a search found, in flight order."""

    flights: list[Flight] = field(default_factory=list)
    stopped: str = ""  #: why the search ended ("counterexample", "flight budget", "wall budget", "interrupted")
    wall_s: float = 0.0

    @property
    def best(self) -> Flight | None:
        return min(self.flights, key=lambda f: f.objective, default=None)

    @property
    def counterexample(self) -> Flight | None:
        best = self.best
        return best if best is not None and best.objective < 0 else None


class _Stop(Exception):
    def __init__(self, why: str) -> None:
        super().__init__(why)
        self.why = why


@dataclass(frozen=True)
class Engine:
    """Where flights fly: ``workers`` cases at once on Dask (a LocalCluster, or ``scheduler``)
    or the process pool."""

    rig: Path
    workers: int
    use_dask: bool
    scheduler: str | None
    out: Path
    mode: str = "lockstep"
    case_timeout_s: float = 600.0
    #: more files every case carries (a mutant's tree: hil/fleet/falsify/mutant.py)
    extra_files: Files = field(default_factory=dict)

    @functools.cached_property
    def _rig(self) -> tuple[Files, str]:
        """The rig's files as bytes and its relative path among them (read once per engine)."""
        return rig_files(self.rig, {}, Path.cwd())

    def case(self, space: Space, case_id: str, values: dict[str, float | int], path: Path) -> dict[str, Any]:
        """The flight of the point scenario ``path`` as a campaign case, its files as bytes."""
        shipped_rig, rig_rel = self._rig
        shipped_scenario, scenario_rel = scenario_files(path)
        name = space.scenario.name
        seed = int(values.get("scenario.seed", space.scenario.scenario.seed))
        return {
            "case_id": case_id, "campaign": f"falsify-{name}", "scenario_name": name, "seed": seed,
            "mode": self.mode, "duration_s": None, "flight_overrides": {}, "rig_overrides": {},
            "files": {**shipped_rig, **shipped_scenario, **self.extra_files}, "rig": rig_rel,
            "scenario": scenario_rel, "log_name": f"{case_id}_{name}_s{seed}.mcap", "keep_logs": "failed",
            "timeout_s": self.case_timeout_s, "stop_file": str(self.out / "STOP"), "stop_event": None,
        }

    def fly(self, cases: list[dict[str, Any]], handle: Callable[[dict[str, Any]], None]) -> bool:
        """Fly ``cases``; each landed result to ``handle``. True when interrupted (Ctrl-C)."""
        stop_file = self.out / "STOP"
        if self.use_dask:
            interrupted, _ = run_dask(cases, self.workers, self.scheduler, run_bundled_case, handle, stop_file,
                                      self.out.name)
        else:
            interrupted, _ = run_pool(cases, self.workers, run_bundled_case, handle, stop_file)
        return interrupted


def run_search(space: Space, engine: Engine, *, flights: int, wall_s: float | None, seed: int,
               on_flight: Callable[[Flight, int], None] = lambda f, n: None, focus: tuple[str, ...] = ()) -> Search:
    """Search ``space`` for a flight that fails; at most ``flights`` flights (whole
    generations) and ``wall_s`` wall seconds. ``on_flight(flight, budget)``: progress.
    ``focus``: only the criteria it names count (objective.focused)."""
    from scipy.optimize import differential_evolution

    criteria: dict[str, Criterion] = {c.name: c for c in space.scenario.criteria}
    search = Search()
    t0 = clock.monotonic_ns()
    generation = 0
    n_dims = len(space.vary)
    popsize = max(5, math.ceil(max(engine.workers, 8) / n_dims))  # scipy flies popsize * dims a generation

    def fly_generation(_: Callable[..., float], xs: Any) -> list[float]:
        nonlocal generation
        points = [np.asarray(x, dtype=float) for x in xs]
        if search.flights and len(search.flights) + len(points) > flights:  # the first generation always flies
            raise _Stop("flight budget")
        if search.flights and wall_s is not None and (clock.monotonic_ns() - t0) / 1e9 >= wall_s:
            raise _Stop("wall budget")
        cases: list[dict[str, Any]] = []
        by_id: dict[str, tuple[int, dict[str, float | int], Path]] = {}
        for x in points:
            index = len(search.flights) + len(cases)
            values = space.values(x)
            path = space.write(values, engine.out / "points" / f"{index:04d}.toml",
                               f"hil falsify {space.path.name}: point {index}, generation {generation}")
            case_id = f"{index:04d}"
            by_id[case_id] = (index, values, path)
            cases.append(engine.case(space, case_id, values, path))
        landed: dict[str, Flight] = {}

        def handle(result: dict[str, Any]) -> None:
            result = land_result(result, engine.out)
            index, values, path = by_id[result["case_id"]]
            objective, worst = robustness(result, criteria, focus)
            flight = Flight(index, generation, values, objective, worst, str(result.get("end_reason")), path,
                            result.get("log"), float(result.get("wall_s") or 0.0))
            landed[result["case_id"]] = flight
            on_flight(flight, max(flights, len(points)))  # a first generation larger than the budget flies whole

        interrupted = engine.fly(cases, handle)
        done = [landed[c["case_id"]] for c in cases if c["case_id"] in landed]
        search.flights.extend(sorted(done, key=lambda f: f.index))
        generation += 1
        if interrupted or len(done) < len(cases):
            raise _Stop("interrupted")
        if any(f.objective < 0 for f in done):
            raise _Stop("counterexample")
        return [f.objective for f in sorted(done, key=lambda f: f.index)]

    # A population that converged (every flight as far from failing as the others) restarts
    # from fresh draws while the budget lasts: the search ends on a failure or the budget.
    for restart in range(flights):
        try:
            differential_evolution(
                lambda x: math.nan,  # never called: fly_generation flies each generation itself
                space.bounds(), integrality=space.integrality(), seed=seed + 7919 * restart, popsize=popsize,
                maxiter=max(1, flights), polish=False, updating="deferred", workers=fly_generation,
                init="latinhypercube", tol=0.0, atol=0.0)
        except _Stop as stop:
            search.stopped = stop.why
            break
    search.wall_s = (clock.monotonic_ns() - t0) / 1e9
    return search


def fly_reference(space: Space, engine: Engine, flight: Flight, focus: tuple[str, ...] = ()) -> Flight | None:
    """``flight``'s point flown again without the engine's extra files: with ``--mutant``, the
    unmodified flight code on the mutant's counterexample. It separates the two when this
    flight passes (the criteria ``focus`` names). None when interrupted."""
    plain = dataclasses.replace(engine, extra_files={})
    landed: list[dict[str, Any]] = []
    if plain.fly([plain.case(space, "reference", flight.values, flight.scenario_file)], landed.append) or not landed:
        return None
    result = land_result(landed[0], engine.out)
    objective, worst = robustness(result, {c.name: c for c in space.scenario.criteria}, focus)
    return Flight(flight.index, flight.generation, flight.values, objective, worst, str(result.get("end_reason")),
                  flight.scenario_file, result.get("log"), float(result.get("wall_s") or 0.0))


__all__ = ["Engine", "Flight", "Search", "fly_reference", "run_search"]
