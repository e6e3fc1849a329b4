"""Scenario files: what happens during a run and how it is judged.

A scenario (``rigs/scenarios/<name>.toml``) scripts the RC sticks, plant events (wind,
gusts, payload), faults, the run duration, optional overrides of the flight code's
config, and the pass/fail criteria evaluated on the run's trace. Everything is in sim
time (seconds in the file, ns inside).

    [scenario]
    name = "hover"
    duration_s = 30.0

    [[sticks]]            # setpoint with a ramp, a sine, a gesture or a signal loss
    t_s = 0.5
    action = "arm"

    [wind]                # optional: replaces the rig's [plant.wind] (hil/plant/params.py)
    mean_N_mps = [2.0, 0.0, 0.0]
    dryden = true

    [[events]]
    t_s = 15.0
    kind = "payload"
    extra_mass_kg = 0.3

    [[criteria]]
    name = "roll held"
    signal = "truth.roll_deg"
    metric = "max_abs"
    window_s = [8.0, 30.0]
    max = 3.0
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hil.config import ConfigError, load_toml, validate
from hil.plant.params import WindParams

S_TO_NS = 1_000_000_000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ScenarioHeader(_Strict):
    name: str
    description: str = ""
    duration_s: float = Field(gt=0)
    seed: int = 1
    #: The phase shown in the progress bar: list of (t_s, label), increasing.
    phases: list[tuple[float, str]] = []


class SineSpec(_Strict):
    amplitude_us: float = Field(ge=0, le=500)
    freq_hz: float = Field(gt=0)
    duration_s: float = Field(gt=0)
    offset_us: float | None = None
    fade_s: float = Field(default=2.0, ge=0)


class StickEntry(_Strict):
    """One line of the stick script; exactly one of pulse_us / sine / action."""

    t_s: float = Field(ge=0)
    channel: int | None = Field(default=None, ge=1, le=8)
    pulse_us: float | None = Field(default=None, ge=800, le=2200)
    ramp_s: float = Field(default=0.0, ge=0)
    sine: SineSpec | None = None
    action: Literal["arm", "disarm", "loss"] | None = None
    duration_s: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _one_kind(self) -> StickEntry:
        kinds = [self.pulse_us is not None, self.sine is not None, self.action is not None]
        if sum(kinds) != 1:
            raise ValueError("give exactly one of pulse_us, sine or action")
        if (self.pulse_us is not None or self.sine is not None) and self.channel is None:
            raise ValueError("pulse_us and sine need a channel (1..8)")
        if self.action == "loss" and self.duration_s is None:
            raise ValueError("action 'loss' needs duration_s")
        if self.action in ("arm", "disarm") and self.duration_s is not None and self.duration_s <= 1.0:
            raise ValueError("an arm/disarm gesture must be held longer than the 1 s the flight code needs (duration_s)")
        return self


class PayloadEvent(_Strict):
    kind: Literal["payload"]
    t_s: float = Field(ge=0)
    extra_mass_kg: float = Field(ge=0, le=2.0)
    r_B_m: tuple[float, float, float] = (0.0, 0.0, 0.1)


class WindEvent(_Strict):
    """Constant wind added from t_s for duration_s (None = to the end): a step or a gust."""

    kind: Literal["wind"]
    t_s: float = Field(ge=0)
    wind_N_mps: tuple[float, float, float]
    duration_s: float | None = Field(default=None, gt=0)


class GustEvent(_Strict):
    """A (1 - cos) gust of peak ``wind_N_mps`` lasting ``duration_s``."""

    kind: Literal["gust"]
    t_s: float = Field(ge=0)
    wind_N_mps: tuple[float, float, float]
    duration_s: float = Field(gt=0)


PlantEvent = Annotated[PayloadEvent | WindEvent | GustEvent, Field(discriminator="kind")]


class Criterion(_Strict):
    """A pass/fail check on one signal of the run's trace (see hil/analysis/criteria.py)."""

    name: str
    signal: str
    metric: Literal[
        "max_abs", "rms", "mean", "min", "max", "final", "p99_abs", "amplitude", "std",
        "rms_delta", "overshoot", "settling_time", "fraction_saturated", "rise_time",
        "phase_lag_deg", "rms_change_pct", "increase", "fraction_in", "fraction_finite",
    ]
    window_s: tuple[float, float] | None = None
    max: float | None = None
    min: float | None = None
    #: metric parameters: target (overshoot/settling/rise), band (settling), step_t_s,
    #: lo/hi (fraction_saturated, fraction_in)
    target: float | None = None
    band: float | None = None
    step_t_s: float | None = None
    start: float | None = None
    lo: float | None = None
    hi: float | None = None
    #: step metrics against the height before the step: target = mean of the signal over
    #: ``pre_step_s`` before ``step_t_s`` + ``step_size`` (start = that mean); the settling
    #: band as a fraction of the step size (0.05 = +-5 %)
    step_size: float | None = None
    pre_step_s: float = Field(default=1.0, gt=0)
    band_fraction: float | None = Field(default=None, gt=0)
    #: phase_lag_deg: lag of ``signal`` behind ``reference`` at ``freq_hz`` (positive = late)
    reference: str | None = None
    freq_hz: float | None = Field(default=None, gt=0)
    #: rms_change_pct: 100 (RMS over window_s / RMS over baseline_window_s - 1)
    baseline_window_s: tuple[float, float] | None = None
    #: share of the window's samples that may be non-finite (NaN, inf) before the criterion
    #: fails; 0: any non-finite sample fails it
    nonfinite_fraction_max: float = Field(default=0.0, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _has_bound(self) -> Criterion:
        if self.max is None and self.min is None:
            raise ValueError("a criterion needs max and/or min")
        if self.metric == "phase_lag_deg" and (self.reference is None or self.freq_hz is None):
            raise ValueError("phase_lag_deg needs reference and freq_hz")
        if self.metric == "rms_change_pct" and (self.baseline_window_s is None or self.window_s is None):
            raise ValueError("rms_change_pct needs window_s and baseline_window_s")
        if self.step_size is not None and self.target is not None:
            raise ValueError("give one of target or step_size")
        if self.metric == "fraction_in" and self.lo is None and self.hi is None:
            raise ValueError("fraction_in needs lo and/or hi (the range a sample must be in)")
        if self.metric == "overshoot" and (self.min is None or self.max is None):
            raise ValueError("overshoot needs min and max (an undershoot, a step short of its size, must fail too)")
        return self


class Vary(_Strict):
    """One quantity ``hil falsify`` may vary: a dotted key into this scenario file's own tables
    (``faults.0.duration_s``, ``scenario.seed``, ``wind.mean_N_mps.0``, ``sticks.1.pulse_us``),
    its range, and whether it takes whole numbers (a seed)."""

    key: str
    range: tuple[float, float]
    integer: bool = False

    @model_validator(mode="after")
    def _ordered(self) -> Vary:
        if not self.range[0] < self.range[1]:
            raise ValueError(f"range of {self.key!r} must be [lo, hi] with lo < hi (got {list(self.range)})")
        return self


class FalsifySpec(_Strict):
    """``[falsify]``: what ``hil falsify`` may vary (docs/falsify.md)."""

    vary: list[Vary] = Field(min_length=1)


class Scenario(_Strict):
    scenario: ScenarioHeader
    flight: dict[str, Any] = {}
    #: Replaces the rig's ``[plant.wind]`` for this run (mean wind, turbulence), e.g.
    #: ``[wind] mean_N_mps = [2.0, 1.0, 0.0]`` + ``dryden = true``. Same keys and checks.
    wind: WindParams | None = None
    sticks: list[StickEntry] = []
    events: list[PlantEvent] = []
    faults: list[dict[str, Any]] = []
    criteria: list[Criterion] = []
    timing: dict[str, float] = {}
    falsify: FalsifySpec | None = None

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def duration_ns(self) -> int:
        return int(round(self.scenario.duration_s * S_TO_NS))


def apply_to_rig(rig: Any, scenario: Scenario) -> Any:
    """The rig as flown in ``scenario``: its ``[wind]`` (if any) replaces ``[plant.wind]``."""
    if scenario.wind is None:
        return rig
    return replace(rig, plant=replace(rig.plant, wind=scenario.wind))


def load_scenario(path: Path) -> Scenario:
    """Read and validate a scenario file (errors name file, key and reason)."""
    data = load_toml(path)
    scenario = validate(Scenario, data, file=path, section="")
    last = -1.0
    for i, entry in enumerate(scenario.sticks):
        if entry.t_s < last:
            raise ConfigError(f"{path}: [[sticks]] {i}.t_s: times must not decrease ({entry.t_s} < {last})")
        last = entry.t_s
    return scenario
