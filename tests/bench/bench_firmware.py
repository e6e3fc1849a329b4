"""The C flight code (firmware/) on the bench, measured. Not a test; run it when the firmware or
the flight code changes:

    .venv/bin/python tests/bench/bench_firmware.py cpu [--scenario hover] [--seed 1] [--rounds 2]
    .venv/bin/python tests/bench/bench_firmware.py suite [--seeds 1-3] [--workers 1] [SCENARIO ...]

``cpu``: the same scenario and seed flown with each flight code in one run of this script,
alternating (Python, C, Python, C ...) so that both meet the same load; prints each flight's
``fc_cpu_per_tick_us`` (the flight code's CPU time per 2.5 ms sample, hil/flight/run_result.py)
and RTF, the medians, and the ratio Python / C (the firmware's target: at least 5).

``suite``: every shipped scenario with the C flight code on the given seeds (the criteria of
tests/system/test_scenarios.py; the paper-literal demonstration must fail on control
activity); one line per run, the pass count, exit 0 when all did what they should.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
C_RIG = str(ROOT / "rigs" / "paper-quad-c.toml")
EXPECTED_TO_FAIL = {"paper-literal-weights": {"control activity: sample-to-sample ESC change"}}


def _fly(rig_name: str | None, scenario: str, seed: int, record: bool = False) -> object:
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario
    from hil.flight.run import run_flight_async
    from hil.flight.tickloop import Mode

    rig = load_rig(rig_name)
    source = rig.scenario_path(scenario)
    with tempfile.TemporaryDirectory() as out:
        return asyncio.run(run_flight_async(rig, load_scenario(source), scenario_source=source, seed=seed,
                                            mode=Mode.LOCKSTEP, out_dir=Path(out), record=record))


def _build() -> None:
    sys.path.insert(0, str(ROOT))
    from tests.unit.firmware.fwbuild import host_binary

    host_binary()


def cpu(args: argparse.Namespace) -> int:
    _build()
    runs: dict[str, list[tuple[float, float]]] = {"python": [], "c": []}
    for k in range(args.rounds):
        for label, rig in (("python", None), ("c", C_RIG)):
            result = _fly(rig, args.scenario, args.seed, record=True)
            t = result.timing  # type: ignore[attr-defined]
            runs[label].append((t["fc_cpu_per_tick_us"], t["rtf"]))
            print(f"round {k + 1} {label:6s} {args.scenario} seed {args.seed}: passed={result.passed} "  # type: ignore[attr-defined]
                  f"fc_cpu_per_tick_us={t['fc_cpu_per_tick_us']:.1f} rtf={t['rtf']:.3f}", flush=True)
    med = {k: (statistics.median(c for c, _ in v), statistics.median(r for _, r in v)) for k, v in runs.items()}
    ratio = med["python"][0] / med["c"][0]
    print(f"median fc_cpu_per_tick_us: python {med['python'][0]:.1f}, c {med['c'][0]:.1f} -> ratio {ratio:.1f} "
          f"(target >= 5); median rtf: python {med['python'][1]:.3f}, c {med['c'][1]:.3f}")
    return 0 if ratio >= 5.0 else 1


def _suite_one(name: str, seed: int) -> tuple[str, int, bool, list[str]]:
    result = _fly(C_RIG, name, seed)
    failed = {c.name: f"{c.name} = {c.value:.4g} ({c.bound}) {c.detail}" for c in result.criteria  # type: ignore[attr-defined]
              if not c.passed}
    ended = result.end_reason.value == "completed"  # type: ignore[attr-defined]
    if name in EXPECTED_TO_FAIL:
        ok = ended and EXPECTED_TO_FAIL[name] <= set(failed)
    else:
        ok = ended and not failed
    notes = list(failed.values())
    if not ended:
        notes.append(f"ended: {result.end_reason.value} {result.message}")  # type: ignore[attr-defined]
    return name, seed, ok, notes


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def suite(args: argparse.Namespace) -> int:
    from hil.config import SCENARIOS_DIR

    _build()
    names = args.scenarios or sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml"))
    jobs = [(n, s) for s in _seeds(args.seeds) for n in names]
    ok_count = 0
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = [pool.submit(_suite_one, n, s) for n, s in jobs]
        for fut in as_completed(futures):
            name, seed, ok, notes = fut.result()
            ok_count += ok
            print(f"{'ok  ' if ok else 'FAIL'} {name} seed {seed}" + (f": {'; '.join(notes)}" if notes else ""),
                  flush=True)
    print(f"{ok_count} of {len(jobs)} runs did what they should")
    return 0 if ok_count == len(jobs) else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    c = sub.add_parser("cpu")
    c.add_argument("--scenario", default="hover")
    c.add_argument("--seed", type=int, default=1)
    c.add_argument("--rounds", type=int, default=2)
    s = sub.add_parser("suite")
    s.add_argument("--seeds", default="1-3")
    s.add_argument("--workers", type=int, default=1)
    s.add_argument("scenarios", nargs="*")
    args = ap.parse_args()
    return cpu(args) if args.what == "cpu" else suite(args)


if __name__ == "__main__":
    sys.exit(main())
