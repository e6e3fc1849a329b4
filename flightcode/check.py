"""``python -m flightcode --config FILE --check-config``: validate the config, start nothing.

The bench asks the flight code itself whether a rig's and a scenario's ``[flight]`` overrides
make a valid config (it never imports the flight code). The answer is one JSON line on
stdout, the verdict of :func:`flightcode.config.load`:

    {"flightcode_check": 1, "ok": true}
    {"flightcode_check": 1, "ok": false, "file": "...", "key": "attitude.kp", "reason": "unknown key ..."}

and the exit status: 0 valid, 2 invalid (the reason also on stderr, as a normal start says it).
"""

from __future__ import annotations

import json
import sys

from flightcode.config import ConfigError, load

EXIT_OK, EXIT_CONFIG = 0, 2
#: version of the answer's format
CHECK_FORMAT = 1


def check_config(path: str) -> int:
    """Print the verdict on the config at ``path`` (module docstring); returns the exit status."""
    try:
        load(path)
    except ConfigError as exc:
        print(json.dumps({"flightcode_check": CHECK_FORMAT, "ok": False, "file": exc.file, "key": exc.key,
                          "reason": exc.reason}), flush=True)
        print(f"flightcode: invalid config: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    print(json.dumps({"flightcode_check": CHECK_FORMAT, "ok": True}), flush=True)
    return EXIT_OK
