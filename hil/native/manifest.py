"""The compiled build's manifest: what it holds, for which Python and checkout, from which sources.

``hil build`` writes ``manifest.json`` last, into the build directory, beside the extension
modules. The loader (hil/native/loader.py) uses the build only when the manifest matches this
interpreter, this checkout, and every watched source's SHA-256. A source whose size and
mtime are unchanged is taken as unchanged without hashing it (a ``git checkout`` that touches a
file without changing it costs one hash, then nothing).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import sysconfig
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

FILE = "manifest.json"
FORMAT = 1


@dataclass(frozen=True)
class SourceStamp:
    """One watched source as the build compiled it."""

    sha256: str
    size: int
    mtime_ns: int

    @classmethod
    def of(cls, path: Path) -> SourceStamp:
        st = path.stat()
        return cls(hashlib.sha256(path.read_bytes()).hexdigest(), st.st_size, st.st_mtime_ns)

    def matches(self, path: Path) -> bool:
        """Whether ``path`` still holds the source this stamp was taken of."""
        try:
            st = path.stat()
        except OSError:
            return False
        if st.st_size != self.size:
            return False
        if st.st_mtime_ns == self.mtime_ns:
            return True
        return hashlib.sha256(path.read_bytes()).hexdigest() == self.sha256


def interpreter_tag() -> str:
    """The ABI the extension modules were built for (``cpython-311-x86_64-linux-gnu``)."""
    return f"{sys.implementation.cache_tag}-{sysconfig.get_platform()}"


@dataclass(frozen=True)
class Manifest:
    """A build: its modules (dotted name -> ``.so`` path relative to the build directory), the
    sources it watched (path relative to ``root`` -> stamp), and how it was built."""

    root: str
    interpreter: str
    opt_level: str
    built_ns: int
    #: sources.GROUPINGS: how mypyc grouped the modules (a build before the option: "modules")
    groups: str = "modules"
    modules: dict[str, str] = field(default_factory=dict)
    sources: dict[str, SourceStamp] = field(default_factory=dict)

    def changed_sources(self) -> list[str]:
        """The watched sources that are no longer the ones compiled (edited, removed), sorted."""
        root = Path(self.root)
        return sorted(rel for rel, stamp in self.sources.items() if not stamp.matches(root / rel))

    def to_json(self) -> str:
        data: dict[str, Any] = {
            "format": FORMAT, "root": self.root, "interpreter": self.interpreter,
            "opt_level": self.opt_level, "groups": self.groups, "built_ns": self.built_ns, "modules": self.modules,
            "sources": {k: [v.sha256, v.size, v.mtime_ns] for k, v in self.sources.items()},
        }
        return json.dumps(data, indent=1, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> Manifest:
        """Parse a manifest; anything that is not one of this format raises ``ValueError``
        with the reason (a damaged file, another tool's JSON, a hand edit)."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"not JSON ({exc})") from None
        if not isinstance(data, dict):
            raise ValueError(f"not a manifest: a JSON {type(data).__name__}, expected an object")
        if data.get("format") != FORMAT:
            raise ValueError(f"manifest format {data.get('format')!r}, expected {FORMAT}")
        try:
            modules = data["modules"]
            sources = data["sources"]
            if not isinstance(modules, dict) or not isinstance(sources, dict):
                raise TypeError("'modules' and 'sources' must be objects")
            return cls(root=str(data["root"]), interpreter=str(data["interpreter"]),
                       opt_level=str(data["opt_level"]), groups=str(data.get("groups", "modules")),
                       built_ns=int(data["built_ns"]),
                       modules={str(k): str(v) for k, v in modules.items()},
                       sources={str(k): SourceStamp(str(v[0]), int(v[1]), int(v[2])) for k, v in sources.items()})
        except KeyError as exc:
            raise ValueError(f"manifest lacks key {exc}") from None
        except (TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"manifest malformed: {exc}") from None

    def write(self, directory: Path) -> None:
        tmp = directory / (FILE + ".tmp")
        tmp.write_text(self.to_json())
        os.replace(tmp, directory / FILE)


def read(directory: Path) -> Manifest | None:
    """The manifest in ``directory``; None when there is no build there."""
    try:
        return Manifest.from_json((directory / FILE).read_text())
    except FileNotFoundError:
        return None
