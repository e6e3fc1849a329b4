"""Configuration: rig and scenario files -> validated, frozen models.

- :mod:`hil.config.files`: TOML reading, validation into parameter classes, errors naming file,
  key and reason (:class:`ConfigError`), where rigs and scenarios are found;
- :mod:`hil.config.rig`: a rig (one vehicle and its wiring);
- :mod:`hil.config.scenario`: a scenario (what happens during a run and how it is judged);
- :mod:`hil.config.attach`: rig ports on real serial devices.

The names of :mod:`hil.config.files` are importable from here, as they were when this package
was one module.
"""

from hil.config.files import (
    DEFAULT_RIG,
    RIGS_DIR,
    ROOT,
    SCENARIOS_DIR,
    ConfigError,
    check_keys,
    load_toml,
    resolve_rig,
    resolve_scenario,
    validate,
)

__all__ = ["DEFAULT_RIG", "RIGS_DIR", "ROOT", "SCENARIOS_DIR", "ConfigError", "check_keys", "load_toml",
           "resolve_rig", "resolve_scenario", "validate"]
