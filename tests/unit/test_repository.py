"""The repository holds sources, not build products.

A compiled extension module in git shadows its ``.py`` source on every checkout, and breaks any
checkout whose interpreter or build differs (the tracked modules import a shared library that
only one machine had). Build products go in .gitignore; this test fails when one is tracked.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: suffixes of compiled or generated build products
BUILD_SUFFIXES = (".so", ".pyd", ".dll", ".dylib", ".o", ".a", ".pyc")
#: magic numbers of executables and object files (ELF, Mach-O, PE)
MAGICS = (b"\x7fELF", b"\xcf\xfa\xed\xfe", b"\xce\xfa\xed\xfe", b"MZ")


def _tracked() -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [p for p in out.stdout.decode().split("\0") if p]


def test_no_build_product_is_tracked() -> None:
    tracked = _tracked()
    by_suffix = [p for p in tracked if p.endswith(BUILD_SUFFIXES) or ".cpython-" in p]
    assert by_suffix == [], f"build products tracked in git (git rm --cached them): {by_suffix}"


def test_no_tracked_file_is_a_binary_executable_or_object() -> None:
    binaries = []
    for rel in _tracked():
        path = ROOT / rel
        if path.is_file():
            with path.open("rb") as f:
                if f.read(4).startswith(MAGICS):
                    binaries.append(rel)
    assert binaries == [], f"compiled binaries tracked in git: {binaries}"


def test_build_products_are_ignored() -> None:
    # a product of each kind the build makes, anywhere in the tree
    probes = ["hil/flight/tickloop.cpython-311-x86_64-linux-gnu.so", "emulators/x/y.so", "hil/vtime/_shim.abi3.so",
              "build/temp/x.o"]
    out = subprocess.run(["git", "check-ignore", "--no-index", *probes], cwd=ROOT, capture_output=True, text=True)
    if out.returncode == 128:
        pytest.skip("not a git checkout")
    assert sorted(out.stdout.split()) == sorted(probes)


# -- references a reader can follow ---------------------------------------------------------

#: names of notes that were kept outside the repository; a reference to one must resolve here
NOTE_NAMES = ("paper", "protocols", "limits", "ecosystem", "aesthetics")
#: ``[dir/...]name.md`` for those names; the path before the name, if any, is group 1
NOTE_REF = re.compile(r"(?<![\w./-])((?:[\w.-]+/)*)(" + "|".join(NOTE_NAMES) + r")\.md\b")
#: a directory of notes outside the repository
RESEARCH_REF = re.compile(r"(?<![\w.-])research/")
#: docs/performance.md is a reference without dated rounds: "performance.md, eighth round"
ROUND_REF = re.compile(r"performance\.md,?\s+\w+\s+round\b")


def _text_files() -> list[tuple[str, str]]:
    files = []
    for rel in _tracked():
        path = ROOT / rel
        if not path.is_file():
            continue
        try:
            files.append((rel, path.read_text(encoding="utf-8")))
        except UnicodeDecodeError:
            continue  # binary (a PNG)
    return files


def dangling_note_refs(rel: str, text: str, exists=lambda p: (ROOT / p).exists()) -> list[str]:
    """``file:line: reference`` for each reference in ``text`` (the file ``rel``) that a reader
    of the repository cannot follow: a ``research/`` path, a note name whose file is not in the
    repository (bare names are looked up in docs/), or a dated round of docs/performance.md."""
    bad = []
    for n, line in enumerate(text.splitlines(), 1):
        for m in RESEARCH_REF.finditer(line):
            bad.append(f"{rel}:{n}: {line[m.start():m.start() + 40].strip()}")
        for m in NOTE_REF.finditer(line):
            prefix, name = m.group(1), m.group(2) + ".md"
            if "research/" in prefix:
                continue  # reported above
            candidates = [f"docs/{name}"] if not prefix else [prefix + name, str(Path(rel).parent / prefix / name)]
            if not any(exists(c) for c in candidates):
                bad.append(f"{rel}:{n}: {m.group(0)}")
        for m in ROUND_REF.finditer(line):
            bad.append(f"{rel}:{n}: {m.group(0)}")
    return bad


def test_every_note_reference_resolves_in_the_repository() -> None:
    this_file = str(Path(__file__).resolve().relative_to(ROOT))  # its examples name the patterns
    bad = [b for rel, text in _text_files() if rel != this_file for b in dangling_note_refs(rel, text)]
    assert bad == [], "references to files that are not in the repository:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "line",
    [
        "see research/paper.md 2.6",
        "(paper.md 3.2)",
        "limits.md section 4",
        "ecosystem.md §7",
        "docs/aesthetics.md",
        "research/golden/xsens-mti300-captures.md",
        "(docs/performance.md, eighth round)",
    ],
)
def test_a_dangling_reference_is_reported(line: str) -> None:
    assert dangling_note_refs("hil/x.py", line) != []


@pytest.mark.parametrize("line", ["docs/controllers.md 2.6", "protocols.md 1.2", "docs/protocols.md §7.1",
                                  "docs/performance.md, Builds"])
def test_a_reference_that_resolves_is_accepted(line: str) -> None:
    assert dangling_note_refs("hil/x.py", line) == []
