"""Load the compiled build when, and only when, it is the build of the sources on disk.

``install()`` runs once, at ``import hil``. It reads the build's manifest (hil/native/manifest.py)
and decides:

- no build, or ``HIL_NATIVE=0``: everything runs interpreted;
- a build for another interpreter or another checkout: interpreted, and says why;
- a build older than any watched source (an edit, a ``git pull``): interpreted, with a warning
  naming the sources and the command that rebuilds. Python never runs a stale build;
- a fresh build: a finder at the head of ``sys.meta_path`` serves its extension modules.

Only ``hil`` installs the finder (``emulators`` may not import ``hil``): a process that imports
``emulators`` first runs it interpreted. Mixing is refused: if a compiled module was already
imported from its source when ``hil`` is imported, the whole build stays unused, since compiled
code that receives an interpreted instance of a class it compiled raises ``TypeError``.
"""

from __future__ import annotations

import enum
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from importlib.machinery import ModuleSpec
from pathlib import Path
from types import ModuleType

from hil.native import manifest as manifest_mod
from hil.native.sources import project_root

#: set to 0 to run interpreted whatever is built (the equivalence test's interpreted side)
ENV_SWITCH = "HIL_NATIVE"
#: where ``hil build`` puts the build (default: inside the environment, per interpreter)
ENV_DIR = "HIL_NATIVE_DIR"


class Why(enum.Enum):
    """Why this process runs the way it does."""

    COMPILED = "compiled"
    NOT_BUILT = "not built"
    SWITCHED_OFF = "switched off"
    STALE = "stale"
    OTHER_BUILD = "built for another interpreter or checkout"
    UNREADABLE = "unreadable"
    IMPORTED_FIRST = "imported before hil"


@dataclass(frozen=True)
class LoadState:
    """What ``install()`` decided: the build directory, why, and the details behind it."""

    directory: Path
    why: Why
    changed: tuple[str, ...] = ()
    detail: str = ""
    opt_level: str = ""
    groups: str = ""
    built_ns: int = 0

    @property
    def compiled(self) -> bool:
        return self.why is Why.COMPILED


class _CompiledFinder(importlib.abc.MetaPathFinder):
    """Serves the build's extension modules by name; everything else falls through."""

    def __init__(self, directory: Path, modules: dict[str, str], root: Path) -> None:
        self._directory = directory
        self._modules = modules
        self._root = root
        self._packages = {name for name, rel in modules.items() if Path(rel).name.startswith("__init__.")}

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: ModuleType | None = None) -> ModuleSpec | None:
        rel = self._modules.get(fullname)
        if rel is None:
            return self._source_spec(fullname)
        origin = self._directory / rel
        loader = importlib.machinery.ExtensionFileLoader(fullname, str(origin))
        # a compiled package's submodules (compiled or not) are found beside its sources
        package = [str(self._root.joinpath(*fullname.split(".")))] if origin.name.startswith("__init__.") else None
        return importlib.util.spec_from_file_location(fullname, origin, loader=loader,
                                                      submodule_search_locations=package)

    def _source_spec(self, fullname: str) -> ModuleSpec | None:
        """An interpreted module inside a compiled package. mypyc sets a compiled package's
        ``__path__`` to the build directory, which holds no sources."""
        if fullname.rpartition(".")[0] not in self._packages:
            return None
        base = self._root.joinpath(*fullname.split("."))
        if (base / "__init__.py").is_file():
            return importlib.util.spec_from_file_location(fullname, base / "__init__.py",
                                                          submodule_search_locations=[str(base)])
        source = base.with_suffix(".py")
        return importlib.util.spec_from_file_location(fullname, source) if source.is_file() else None


def build_dir() -> Path:
    """Where ``hil build`` writes, and where the loader looks: ``$HIL_NATIVE_DIR``, or
    ``<sys.prefix>/share/mav-hil-bench/native/<interpreter tag>``."""
    override = os.environ.get(ENV_DIR)
    if override:
        return Path(override)
    return Path(sys.prefix) / "share" / "mav-hil-bench" / "native" / manifest_mod.interpreter_tag()


def _decide(directory: Path, root: Path) -> tuple[LoadState, manifest_mod.Manifest | None]:
    if os.environ.get(ENV_SWITCH, "") in ("0", "false", "no"):
        return LoadState(directory, Why.SWITCHED_OFF, detail=f"{ENV_SWITCH}=0"), None
    try:
        return _decide_from_manifest(directory, root)
    except Exception as exc:  # noqa: BLE001 - ``import hil`` must never fail on the build directory
        return LoadState(directory, Why.UNREADABLE, detail=f"{directory / manifest_mod.FILE}: {exc}"), None


def _decide_from_manifest(directory: Path, root: Path) -> tuple[LoadState, manifest_mod.Manifest | None]:
    m = manifest_mod.read(directory)
    if m is None:
        return LoadState(directory, Why.NOT_BUILT), None
    if m.interpreter != manifest_mod.interpreter_tag() or Path(m.root) != root:
        return LoadState(directory, Why.OTHER_BUILD, detail=f"{m.interpreter} for {m.root}"), None
    changed = tuple(m.changed_sources())
    if changed:
        return LoadState(directory, Why.STALE, changed=changed, opt_level=m.opt_level, groups=m.groups,
                         built_ns=m.built_ns), None
    early = sorted(name for name in m.modules if name in sys.modules)
    if early:
        return LoadState(directory, Why.IMPORTED_FIRST, detail=", ".join(early[:3])), None
    return LoadState(directory, Why.COMPILED, opt_level=m.opt_level, groups=m.groups, built_ns=m.built_ns), m


def rebuild_command(groups: str = "modules") -> str:
    """The command that compiles a build like this one again (its grouping kept)."""
    return "hil build" if groups in ("", "modules") else f"hil build --groups {groups}"


def stale_message(changed: Sequence[str], groups: str = "modules") -> str:
    """One sentence for a stale build: which sources, what runs instead, how to rebuild."""
    names = ", ".join(changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3 else "")
    return (f"the compiled build is older than {names}: running interpreted (slower, the same "
            f"flight); `{rebuild_command(groups)}` recompiles")


class Loader:
    """Decides once per process and remembers the decision (``state``)."""

    def __init__(self) -> None:
        self._state: LoadState | None = None

    @property
    def state(self) -> LoadState:
        if self._state is None:
            self.install()
        assert self._state is not None
        return self._state

    def install(self) -> LoadState:
        """Install the finder if the build is fresh; never raises. Idempotent."""
        if self._state is not None:
            return self._state
        root = project_root()
        state, m = _decide(build_dir(), root)
        if m is not None:
            sys.meta_path.insert(0, _CompiledFinder(state.directory, dict(m.modules), root))
        elif state.why is Why.STALE:
            # stderr, not warnings.warn: this runs at ``import hil``, before any filter a user could set
            sys.stderr.write(f"warning: {stale_message(state.changed, state.groups)}\n")
        self._state = state
        return state


LOADER = Loader()
