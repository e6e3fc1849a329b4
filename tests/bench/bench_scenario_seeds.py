"""Zero false alarms: every shipped scenario, flown with the unmodified flight code on seeds
1-10 (lockstep), must pass. Not a test (about 14 scenarios x 10 seeds x 0.5-2 min of this
machine); run it when a scenario or the flight code changes:

    .venv/bin/python tests/bench/bench_scenario_seeds.py [--seeds 1-10] [--workers 2] [SCENARIO ...]

Prints one line per run and the pass count; exit 0 when every run passed (scenarios that fail
on purpose, tests/system/test_scenarios.py EXPECTED_TO_FAIL, are left out).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

EXPECTED_TO_FAIL = {"paper-literal-weights"}


def _fly(name: str, seed: int) -> tuple[str, int, bool, list[str]]:
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario
    from hil.flight.run import run_flight_async
    from hil.flight.tickloop import Mode

    rig = load_rig(None)
    source = rig.scenario_path(name)
    with tempfile.TemporaryDirectory() as out:
        result = asyncio.run(run_flight_async(rig, load_scenario(source), scenario_source=source, seed=seed,
                                              mode=Mode.LOCKSTEP, out_dir=Path(out), record=False))
    failed = [f"{c.name} = {c.value:.4g} ({c.bound}) {c.detail}" for c in result.criteria if not c.passed]
    if result.end_reason.value != "completed":
        failed.append(f"ended: {result.end_reason.value} {result.message}")
    return name, seed, result.passed, failed


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> int:
    from hil.config import SCENARIOS_DIR

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-10")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("scenarios", nargs="*")
    args = ap.parse_args()
    names = args.scenarios or sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml") if p.stem not in EXPECTED_TO_FAIL)
    runs = [(n, s) for n in names for s in _seeds(args.seeds)]
    passed = 0
    with ProcessPoolExecutor(args.workers) as pool:
        for fut in as_completed([pool.submit(_fly, n, s) for n, s in runs]):
            name, seed, ok, failed = fut.result()
            passed += ok
            print(f"{'pass' if ok else 'FAIL'}  {name} seed {seed}" + "".join(f"\n      {f}" for f in failed), flush=True)
    print(f"{passed} of {len(runs)} runs passed")
    return 0 if passed == len(runs) else 1


if __name__ == "__main__":
    sys.exit(main())
