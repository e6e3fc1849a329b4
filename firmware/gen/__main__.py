"""``python firmware/gen --config FILE --out DIR`` (or ``python -m gen`` from firmware/).

Exit 0 with the written headers' paths on stdout; exit 2 with one line naming the file, the
key and the reason when the config is invalid (as ``python -m flightcode --check-config``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a directory: make the package importable, and flightcode
    here = Path(__file__).resolve().parent
    sys.path[:0] = [str(here.parent), str(here.parents[1])]
    __package__ = "gen"

from flightcode.config import ConfigError  # noqa: E402

from gen import generate  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="firmware/gen", description="Generate the firmware's design headers.")
    parser.add_argument("--config", required=True, help="flight config TOML (as python -m flightcode reads it)")
    parser.add_argument("--out", required=True, help="directory for the generated headers")
    args = parser.parse_args(argv)
    try:
        paths = generate(args.config, args.out)
    except ConfigError as exc:
        print(f"firmware/gen: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
