"""The firmware's parameter generator: a build step, not part of the bench or the flight code.

It reads a flight config exactly as the Python flight code does (``flightcode.config.load``:
the same defaults, the same errors naming file, key and reason) and writes C headers from
the same design code, so the two flight codes never disagree about the controller:

    python firmware/gen --config rigs/flightcode-paper-quad.toml --out build/gen

A header is rewritten only when its text changes (make then rebuilds only what depends on it).
"""

from __future__ import annotations

from pathlib import Path

from flightcode.config import load

from .sections import SECTIONS


def generate(config: str | Path, out_dir: str | Path) -> list[Path]:
    """Write every section's header for the flight config at ``config`` into ``out_dir``
    (created); returns the headers' paths. ``flightcode.config.ConfigError`` on a bad config."""
    cfg = load(config)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for section in SECTIONS:
        path = out / section.filename
        text = section.render(cfg, str(config))
        if not path.exists() or path.read_text() != text:
            tmp = path.with_suffix(path.suffix + ".tmp")
            tmp.write_text(text)
            tmp.replace(path)
        written.append(path)
    return written
