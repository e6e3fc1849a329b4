"""The compiler's process of ``hil build``: mypyc, then the C compiler, into one directory.

``python -m hil.native.compile OUT --opt-level 2 --jobs 2``, run in the checkout. mypyc
generates C for the modules of hil/native/sources.py, one extension per module
(``separate=True``) so that setuptools compiles them in parallel; the extension modules land
in ``OUT/lib``, mirroring the packages. Progress goes to stdout as lines the parent counts:
``hil-build: N extensions`` once, then setuptools' ``building 'NAME' extension`` per module.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hil.native.sources import compiled_sources, project_root


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hil.native.compile")
    parser.add_argument("out", type=Path)
    parser.add_argument("--opt-level", default="2")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)
    out: Path = args.out.resolve()
    root = project_root()

    from mypyc.build import mypycify
    from setuptools import setup

    # --ignore-missing-imports: third-party modules without types (filterpy, serial) stay Any
    extensions = mypycify(["--ignore-missing-imports", *compiled_sources(root)], opt_level=args.opt_level,
                          debug_level="0", separate=True, target_dir=str(out / "c"))
    print(f"hil-build: {len(extensions)} extensions", flush=True)
    setup(name="hil-native", ext_modules=extensions,
          script_args=["build_ext", "--build-lib", str(out / "lib"), "--build-temp", str(out / "obj"),
                       "--parallel", str(max(1, args.jobs))])
    return 0


if __name__ == "__main__":
    sys.exit(main())
