"""The campaign file: its format, its validation and the cases it expands to.

A campaign file (``rigs/campaigns/*.toml``; format in docs/replay-and-campaigns.md)::

    [campaign]
    name = "hover-seeds"
    rig = "paper-quad"               # name under rigs/, or a path (relative to this file)
    scenarios = ["hover"]            # names (the rig's scenarios/, rigs/scenarios/) or paths
    seeds = { from = 1, count = 20 } # or a list: [1, 2, 3]
    mode = "lockstep"
    duration_s = 10.0                # optional: overrides every scenario's duration
    workers = 1                      # optional: default one per two cores
    out = "logs/campaigns"           # a directory <name>-<UTC time> is made in it
    keep_logs = "failed"             # all | failed | none
    case_timeout_s = 600.0           # wall seconds per case, then it is stopped

    [sweep.flight]                   # the flight code's config (keys of the rig's template)
    "attitude.tau_ff_s" = [0.025, 0.035]
    [sweep.rig]                      # the rig file's tables (plant, imu, ...), validated like it
    "plant.body.mass_kg" = [1.1, 1.4]

:func:`load_campaign` checks every sweep value before anything runs (flight keys against the
flight-config template, rig values by loading the rig with them); :meth:`Campaign.cases` gives
every case, its files as bytes (hil/fleet/campaign_worker.py).
"""

from __future__ import annotations

import enum
import itertools
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import tomli_w
from pydantic import BaseModel, ConfigDict, Field

from hil.config import ConfigError, load_toml, resolve_rig, validate
from hil.fleet.campaign_case import nested


class KeepLogs(enum.StrEnum):
    """Which case logs a campaign keeps: every one, the failed cases' only, or none (then they are not
    recorded at all)."""

    ALL = "all"
    FAILED = "failed"
    NONE = "none"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SeedRange(_Strict):
    first: int = Field(alias="from", ge=0)
    count: int = Field(gt=0, le=1_000_000)


class CampaignHeader(_Strict):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    rig: str = "paper-quad"
    scenarios: list[str] = Field(min_length=1)
    seeds: list[Annotated[int, Field(ge=0)]] | SeedRange = [1]
    mode: Literal["lockstep", "realtime"] = "lockstep"
    duration_s: float | None = Field(default=None, gt=0)
    workers: int | None = Field(default=None, ge=1)
    out: str = "logs/campaigns"
    keep_logs: KeepLogs = KeepLogs.FAILED
    case_timeout_s: float = Field(default=600.0, gt=0)


class SweepTables(_Strict):
    flight: dict[str, Any] = {}
    rig: dict[str, Any] = {}


class CampaignFile(_Strict):
    campaign: CampaignHeader
    sweep: SweepTables = SweepTables()


Sweep = tuple[tuple[str, tuple[Any, ...]], ...]


@dataclass(frozen=True)
class Campaign:
    """A validated campaign file; paths absolute. ``flight_sweep``/``rig_sweep``: (dotted key,
    values) in file order; the cases are scenarios x product(sweeps) x seeds."""

    path: Path
    name: str
    description: str
    rig_path: Path
    scenarios: tuple[tuple[str, Path], ...]
    seeds: tuple[int, ...]
    mode: str
    duration_s: float | None
    workers: int | None
    out_dir: Path
    keep_logs: KeepLogs
    case_timeout_s: float
    flight_sweep: Sweep = ()
    rig_sweep: Sweep = ()

    def points(self) -> list[tuple[dict[str, Any], dict[str, Any]]]:
        """Every sweep point: (flight overrides, rig overrides), dotted keys."""
        keys = [("flight", k) for k, _ in self.flight_sweep] + [("rig", k) for k, _ in self.rig_sweep]
        values = [v for _, v in self.flight_sweep] + [v for _, v in self.rig_sweep]
        out = []
        for combo in itertools.product(*values):
            flight = {k: v for (kind, k), v in zip(keys, combo, strict=True) if kind == "flight"}
            rig = {k: v for (kind, k), v in zip(keys, combo, strict=True) if kind == "rig"}
            out.append((flight, rig))
        return out

    def cases(self, campaign_dir: Path, *, keep_logs: KeepLogs | None = None,
              cwd: Path | None = None) -> list[dict[str, Any]]:
        """Every case, carrying its files as bytes (hil/fleet/campaign_worker.py): the rig, its
        template, the files the flight command names relative to ``cwd`` (default: the current
        directory), the scenario."""
        from hil.fleet.campaign_bundle import rig_files, scenario_files

        here = cwd or Path.cwd()
        out: list[dict[str, Any]] = []
        rigs: dict[str, tuple[dict[str, Any], str]] = {}
        for (scenario_name, scenario_path), (flight, rig), seed in itertools.product(
                self.scenarios, self.points(), self.seeds):
            case_id = f"{len(out):04d}"
            point = repr(sorted(rig.items()))
            if point not in rigs:
                rigs[point] = rig_files(self.rig_path, rig, here)
            shipped_rig, rig_rel = rigs[point]
            shipped_scenario, scenario_rel = scenario_files(scenario_path)
            out.append({
                "case_id": case_id, "campaign": self.name, "scenario_name": scenario_name, "seed": seed,
                "mode": self.mode, "duration_s": self.duration_s, "flight_overrides": flight, "rig_overrides": rig,
                "files": {**shipped_rig, **shipped_scenario}, "rig": rig_rel, "scenario": scenario_rel,
                "log_name": f"{case_id}_{scenario_name}_s{seed}.mcap",
                "keep_logs": (keep_logs or self.keep_logs).value, "timeout_s": self.case_timeout_s,
                "stop_file": str(campaign_dir / "STOP"), "stop_event": None,
            })
        return out


# ---- loading ------------------------------------------------------------------------------------
def _near(value: str, campaign_path: Path) -> Path | None:
    candidate = campaign_path.parent / value
    return candidate.resolve() if candidate.is_file() else None


def _flatten(table: dict[str, Any], file: Path, section: str, prefix: str = "") -> list[tuple[str, tuple[Any, ...]]]:
    out: list[tuple[str, tuple[Any, ...]]] = []
    for k, v in table.items():
        key = f"{prefix}.{k}" if prefix else k
        if isinstance(v, dict):
            out += _flatten(v, file, section, key)
        elif isinstance(v, list) and v:
            out.append((key, tuple(v)))
        else:
            raise ConfigError(f"{file}: [{section}] {key}: a sweep is a non-empty list of values (got {v!r})")
    return out


_MISSING = object()


def _lookup(table: Any, dotted: str) -> Any:
    for part in dotted.split("."):
        if not isinstance(table, dict) or part not in table:
            return _MISSING
        table = table[part]
    return table


def _same_kind(ref: Any, value: Any) -> bool:
    if isinstance(ref, bool) or isinstance(value, bool):
        return isinstance(ref, bool) and isinstance(value, bool)
    if isinstance(ref, (int, float)):
        return isinstance(value, (int, float))
    return type(ref) is type(value)


def _check_flight(sweep: Sweep, template: Path, scenario_tables: list[dict[str, Any]], file: Path) -> None:
    """Flight overrides must name keys the flight code knows: those of its config template (which
    lists every key) or of a scenario's [flight]; values must be of the same kind."""
    tables = [load_toml(template), *scenario_tables]
    for key, values in sweep:
        refs = [r for r in (_lookup(t, key) for t in tables) if r is not _MISSING]
        if not refs:
            raise ConfigError(f"{file}: [sweep.flight] {key}: not a key of the flight config template {template} "
                              "(the flight code rejects unknown keys)")
        for v in values:
            if not _same_kind(refs[0], v) or isinstance(refs[0], dict):
                raise ConfigError(f"{file}: [sweep.flight] {key}: {v!r} is not of the kind of the template's "
                                  f"value {refs[0]!r}")


def _rig_variant(rig_path: Path, overrides: dict[str, Any], dest: Path) -> Path:
    """A copy of the rig with ``overrides`` merged and its flight-config template made absolute."""
    from hil.flight.run import deep_merge

    data = deep_merge(load_toml(rig_path), nested(overrides))
    flight = dict(data.get("flight", {}))
    template = Path(str(flight.get("config", "flightcode-paper-quad.toml")))
    flight["config"] = str(template if template.is_absolute() else (rig_path.parent / template).resolve())
    data["flight"] = flight
    dest.write_text(tomli_w.dumps(data))
    return dest


def _check_rig(sweep: Sweep, rig_path: Path, file: Path) -> None:
    """Each rig override value, merged alone into the rig, must load (component validation)."""
    from hil.config.rig import load_rig

    with tempfile.TemporaryDirectory(prefix="hil-campaign-") as tmp:
        for key, values in sweep:
            for v in values:
                variant = _rig_variant(rig_path, {key: v}, Path(tmp) / rig_path.name)
                try:
                    load_rig(variant)
                except ConfigError as exc:
                    reason = str(exc).replace(f"{variant}: ", "").replace(str(variant), str(rig_path))
                    raise ConfigError(f"{file}: [sweep.rig] {key} = {v!r}: {reason}") from None


def load_campaign(path: Path | str) -> Campaign:
    """Read and validate a campaign file. Errors (ConfigError) name the file, key and reason."""
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario

    path = Path(path).resolve()
    model = validate(CampaignFile, load_toml(path), file=path, section="")
    h = model.campaign
    try:
        rig_path = _near(h.rig, path) or resolve_rig(h.rig).resolve()
    except ConfigError as exc:
        raise ConfigError(f"{path}: [campaign] rig: {exc}") from None
    rig = load_rig(rig_path)
    scenarios: list[tuple[str, Path]] = []
    flights: list[dict[str, Any]] = []
    for entry in h.scenarios:
        try:
            source = _near(entry, path) or rig.scenario_path(entry).resolve()
        except ConfigError as exc:
            raise ConfigError(f"{path}: [campaign] scenarios: {exc}") from None
        scenario = load_scenario(source)
        scenarios.append((scenario.name, source))
        flights.append(scenario.flight)
    seeds = tuple(h.seeds) if isinstance(h.seeds, list) else tuple(range(h.seeds.first, h.seeds.first + h.seeds.count))
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"{path}: [campaign] seeds: a seed appears twice")
    flight_sweep = tuple(_flatten(model.sweep.flight, path, "sweep.flight"))
    rig_sweep = tuple(_flatten(model.sweep.rig, path, "sweep.rig"))
    _check_flight(flight_sweep, rig.flight_config_path, flights, path)
    _check_rig(rig_sweep, rig_path, path)
    return Campaign(path, h.name, h.description, rig_path, tuple(scenarios), seeds, h.mode, h.duration_s,
                    h.workers, Path(h.out), h.keep_logs, h.case_timeout_s, flight_sweep, rig_sweep)


__all__ = ["Campaign", "CampaignFile", "CampaignHeader", "KeepLogs", "SeedRange", "Sweep", "SweepTables",
           "load_campaign"]
