"""The compiler's process of ``hil build``: mypyc, then the C compiler, into one directory.

``python -m hil.native.compile OUT --groups modules --opt-level 2 --jobs 2``, run in the
checkout. mypyc generates C for the modules of hil/native/sources.py, in the groups of
``--groups`` (sources.groups: one per module, compiled in parallel, or one for all); the
extension modules land in ``OUT/lib``, mirroring the packages. Progress goes to stdout as lines
the parent reads: ``hil-build: N extensions`` once, then ``hil-build-largest: FILES LINES
NAME`` (the C of the largest group), then setuptools' ``building 'NAME' extension`` as each
extension starts.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hil.native.sources import GROUPINGS, compiled_sources, groups, project_root


def _c_lines(sources: list[str]) -> int:
    lines = 0
    for source in sources:
        with open(source, "rb") as f:
            lines += sum(1 for _ in f)
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hil.native.compile")
    parser.add_argument("out", type=Path)
    parser.add_argument("--groups", choices=GROUPINGS, default="modules")
    parser.add_argument("--opt-level", default="2")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)
    out: Path = args.out.resolve()
    root = project_root()

    from mypyc.build import mypycify
    from setuptools import setup

    # --ignore-missing-imports: third-party modules without types (filterpy, serial) stay Any
    sources = compiled_sources(root)
    extensions = mypycify(["--ignore-missing-imports", *sources], opt_level=args.opt_level,
                          debug_level="0", separate=groups(sources, args.groups), target_dir=str(out / "c"))
    print(f"hil-build: {len(extensions)} extensions", flush=True)
    largest = max(extensions, key=lambda ext: _c_lines(ext.sources))
    c_files = [s for s in largest.sources if s.endswith(".c")]
    print(f"hil-build-largest: {len(c_files)} {_c_lines(c_files)} {largest.name}", flush=True)
    setup(name="hil-native", ext_modules=extensions,
          script_args=["build_ext", "--build-lib", str(out / "lib"), "--build-temp", str(out / "obj"),
                       "--parallel", str(max(1, args.jobs))])
    return 0


if __name__ == "__main__":
    sys.exit(main())
