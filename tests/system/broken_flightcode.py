"""Deliberately broken copies of the flight code, flown as a rig's ``[flight] command``.

Each variant is one small edit of a copy of flightcode/ (the project's tree is never edited):
``build_rig`` copies the tree, applies the edit (its anchor must occur exactly once in the
whole tree, so a file split does not break it), and writes a rig whose flight command runs
that copy.
"""

from __future__ import annotations

import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from tests.system.conftest import rig_with_command

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Variant:
    name: str
    where: str  #: what the edit touches (for people; the anchor finds the file)
    anchor: str  #: text replaced (must occur exactly once)
    replacement: str
    scenario: str  #: the scenario that must fail
    criteria: frozenset[str]  #: names of criteria of which at least one must fail
    effect: str  #: what it would do to a real vehicle


VARIANTS = [
    Variant(
        "altitude setpoint clamped at 3 m", "stick to altitude setpoint",
        "z = alt_range if z > alt_range else 0.0 if z < 0.0 else z",
        "z = 3.0 if z > 3.0 else 0.0 if z < 0.0 else z",
        "altitude-step",
        frozenset({"overshoot over pre-step + 5 m: reaches the step, at most 1 m over",
                   "settles within +-5 % of pre-step + 5 m", "rise time (10-90 % of the commanded 5 m)"}),
        "a 5 m climb command stops at 3 m",
    ),
    Variant(
        "ADC driver stops reading after its first failed read", "MCP3204 driver",
        "        bridge = self.bridge\n        sent = bridge.counters[\"requests\"]\n",
        "        if self.counters[\"failed_reads\"]:\n            return None\n"
        "        bridge = self.bridge\n        sent = bridge.counters[\"requests\"]\n",
        "fault-adc-garbage",
        frozenset({"the ADC serves its 4 channels per 400 Hz sample again, 13-20 s (bench count, >= 99 %)",
                   "the barometric altitude is finite and on truth again: mean error within 0.5 m"}),
        "after one line glitch the barometer and accelerometer are never read again",
    ),
    Variant(
        "IMU driver takes any SampleTimeFine for real", "XSENS driver",
        "MAX_TIME_SLIP_PERIODS = 4\n", "MAX_TIME_SLIP_PERIODS = 10**9\n",
        "fault-imu-bit-errors",
        frozenset({"the sample clock never runs ahead: telemetry t_s <= 20.1 s"}),
        "a corrupted frame with a matching checksum moves the loop's clock by hours",
    ),
]


def _from_catalogue(mutant_id: str, scenario: str, criteria: set[str]) -> Variant:
    """A variant whose edit is the mutation catalogue's (rigs/mutation/flightcode.toml), so
    that the edit is written once."""
    from hil.config import RIGS_DIR
    from hil.fleet.mutation.catalogue import load_catalogue

    m = next(m for m in load_catalogue(RIGS_DIR / "mutation" / "flightcode.toml").mutant if m.id == mutant_id)
    return Variant(m.id, m.file, m.old, m.new, scenario, frozenset(criteria), m.effect)


VARIANTS += [
    _from_catalogue("mod-no-auto-disarm", "arm-idle", {"disarmed by itself: motors stopped by 8.5 s"}),
    _from_catalogue("tel-rate-halved", "arm-idle", {"telemetry at 50 Hz: >= 380 frames sent in 8 s"}),
    _from_catalogue("drv-ppm-crc-ignored", "fault-rc-bit-errors", {
        "the altitude setpoint stays at the pilot's 2 m (within 0.1 m)", "roll within 3 deg through it",
        "pitch within 3 deg through it"}),
    _from_catalogue("tel-time-units", "arm-idle", {"telemetry time in 0.1 ms: t_s advances 8 s in 8 s"}),
    _from_catalogue("ctl-lqi-windup-upper", "climb-full-throttle", {
        "overshoot over pre-step + 9 m: reaches the step, at most 1.8 m over"}),
    _from_catalogue("ctl-mixer-yaw-not-cut", "climb-full-throttle", {
        "roll follows its reference within 3 deg through the climb", "pitch held within 3 deg through the climb"}),
    _from_catalogue("est-baro-gate-never-reanchors", "fault-baro-shift", {
        "the estimate re-anchors to the barometer: estimate - baro altitude within 0.5 m from 3 s after the shift"}),
    _from_catalogue("drv-baro-rail-exact-only", "fault-baro-wire", {
        "no dip below 1.25 m", "the climb reaches pre-climb + 2 m, at most 0.75 m over",
        "the estimate holds without the barometer: within 0.75 m of truth",
        "the barometer taken back: mean of estimate - baro altitude within 0.5 m from 3 s after"}),
    _from_catalogue("ctl-yaw-integral-cleared-at-centre", "fault-motor-70", {
        "heading held: mean body yaw rate within 1.5 deg/s, 15-20 s"}),
    _from_catalogue("drv-adc-accel-xy-swapped", "transit", {
        "height held in forward flight: no dip below 1.25 m", "height held in forward flight: at most 2.75 m",
        "altitude estimate: RMS error against truth at most 0.25 m",
        "the accelerometers agree: the altitude filter stays on the ADXL335 (tm.accel_from_xsens 0)"}),
    _from_catalogue("est-accel-body-as-vertical", "transit", {
        "height held in forward flight: at most 2.75 m", "altitude estimate: RMS error against truth at most 0.25 m",
        "the accelerometers agree: the altitude filter stays on the ADXL335 (tm.accel_from_xsens 0)"}),
    _from_catalogue("est-euler-rate-no-coupling", "transit", {
        "roll follows its reference through the transit and turn (RMS 0.5 deg, as attitude-0p2hz)"}),
    _from_catalogue("est-baro-flat-check-off", "fault-baro-freeze", {
        "the climb reaches pre-climb + 2 m, at most 0.75 m over",
        "the estimate holds without the barometer: within 0.75 m of truth"}),
    _from_catalogue("est-baro-motion-judged-in-ground-effect", "fault-baro-port-blocked", {
        "the climb reaches pre-climb + 2 m and does not run away: at most 1.5 m over",
        "the estimate flies on the accelerometer: within 0.75 m of truth, 13.5-16 s"}),
]

#: runs the copied flight code: its tree first on sys.path, then flightcode's own main
_RUNNER = """import sys
sys.path.insert(0, {tree!r})
from flightcode.__main__ import main
assert main.__module__ == "flightcode.__main__" and sys.modules["flightcode"].__file__.startswith({tree!r})
sys.argv = ["flightcode", "--config", sys.argv[1]]
sys.exit(main())
"""


def apply(tree: Path, variant: Variant) -> Path:
    """Apply ``variant``'s edit to the copy at ``tree``; returns the file edited."""
    hits = [(p, p.read_text()) for p in sorted((tree / "flightcode").rglob("*.py"))]
    hits = [(p, text) for p, text in hits if variant.anchor in text]
    count = sum(text.count(variant.anchor) for _, text in hits)
    if count != 1:
        raise ValueError(f"{variant.name}: anchor found {count} times in flightcode/")
    target, text = hits[0]
    target.write_text(text.replace(variant.anchor, variant.replacement))
    return target


def build_rig(tmp_path: Path, variant: Variant | None) -> Path:
    """A copy of the default rig that flies a copy of flightcode/ with ``variant`` applied."""
    tree = tmp_path / "tree"
    shutil.copytree(ROOT / "flightcode", tree / "flightcode", ignore=shutil.ignore_patterns("__pycache__"))
    if variant is not None:
        apply(tree, variant)
    runner = tmp_path / "run_copy.py"
    runner.write_text(_RUNNER.format(tree=str(tree)))
    return rig_with_command(tmp_path, ["{python}", str(runner), "{config}"], "broken-rig")


if __name__ == "__main__":  # python -m tests.system.broken_flightcode OUT_DIR INDEX: build one rig
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    print(build_rig(out, VARIANTS[int(sys.argv[2])] if len(sys.argv) > 2 else None))
