"""A test's scenario from what ``hil_bench.start`` was given: a scenario name or path, an inline
dict, a Scenario or nothing, with the test's sticks and flight-config overrides applied."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hil.config.rig import Rig
    from hil.config.scenario import Scenario

#: sim duration of an inline scenario that does not give one (the test usually stops first)
INLINE_DURATION_S = 60.0


def build_scenario(rig: Rig, scenario: str | Path | Mapping[str, Any] | Scenario | None, *,
                   sticks: Sequence[Mapping[str, Any]] | None = None, flight: Mapping[str, Any] | None = None,
                   duration_s: float | None = None, name: str = "pytest") -> tuple[Scenario, Path | None]:
    """The run's scenario and its file: a name or path (rigs/scenarios/), a dict shaped like a
    scenario TOML (``[scenario]`` header optional), a Scenario, or None (empty). ``sticks``
    replace the scenario's [[sticks]]; ``flight`` is deep-merged into its [flight] overrides."""
    from hil.config import ConfigError, validate
    from hil.flight.run import deep_merge
    from hil.config.scenario import Scenario, load_scenario

    source: Path | None = None
    if isinstance(scenario, Scenario):
        scen = scenario
    elif isinstance(scenario, (str, Path)):
        source = rig.scenario_path(scenario)
        scen = load_scenario(source)
    else:
        data = dict(scenario or {})
        header = {"name": name, "duration_s": duration_s or INLINE_DURATION_S} | dict(data.get("scenario", {}))
        scen = validate(Scenario, data | {"scenario": header}, file=f"<inline scenario of {name}>", section="")
    if sticks is not None or flight is not None:
        update: dict[str, Any] = {}
        if sticks is not None:
            update["sticks"] = list(sticks)
        if flight is not None:
            update["flight"] = deep_merge(scen.flight, dict(flight))
        data = scen.model_dump(exclude_none=True) | update
        scen = validate(Scenario, data, file=f"<scenario {scen.name} of {name}>", section="")
    times = [s.t_s for s in scen.sticks]
    if times != sorted(times):
        raise ConfigError(f"<scenario {scen.name} of {name}>: [[sticks]] times must not decrease ({times})")
    return scen, source
