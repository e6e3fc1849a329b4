"""``hil falsify --mutant ID``: search against one catalogue mutant instead of the flight code.

The mutant's tree (the catalogue's ``[target] tree`` with its one edit applied) and the
catalogue's ``[target] context`` files travel with every flight as bytes, in the case's
working directory, where the rig's ``[flight] command`` finds them before the installed
package, as ``hil mutate`` flies them (hil/fleet/mutation/worker.py). No shared filesystem is
needed. The same tree is also written to the search's directory, so the counterexample can be
flown again from there with ``hil run``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hil.config import ConfigError
from hil.fleet.campaign_bundle import WORK_DIR, Files
from hil.fleet.mutation.catalogue import load_catalogue
from hil.fleet.mutation.edits import Edit, context, diff, edited, materialize, snapshot

#: a file's permission bits in a case's bundle (the tree's sources are not executables)
_MODE = 0o644


@dataclass(frozen=True)
class MutantTree:
    """One catalogue mutant, ready to ship: ``files`` relative to the case's root."""

    id: str
    effect: str
    diff: str
    #: the edited tree and the context files, relative path (under the work directory) -> bytes
    sources: dict[str, bytes]

    def bundle(self) -> Files:
        """The files a case carries (hil/fleet/campaign_bundle.py's form: path -> (mode, bytes))."""
        return {f"{WORK_DIR}/{rel}": (_MODE, data) for rel, data in self.sources.items()}

    def write(self, directory: Path) -> Path:
        """The mutant's working directory under ``directory`` (``mutant/``), with ``mutant.diff``."""
        where = directory / "mutant"
        materialize(self.sources, where)
        (directory / "mutant.diff").write_text(self.diff)
        return where


def load_mutant(catalogue: Path, mutant_id: str, tree: Path | None = None) -> MutantTree:
    """Catalogue entry ``mutant_id`` applied to a snapshot of its tree (``tree``, default the
    catalogue's ``[target] tree`` from the working directory). ConfigError naming the
    catalogue and the id when it has no such mutant, or when the edit no longer applies."""
    cat = load_catalogue(catalogue)
    by_id = {m.id: m for m in cat.mutant}
    if mutant_id not in by_id:
        raise ConfigError(f"{catalogue}: --mutant: no mutant {mutant_id!r} (known: {', '.join(sorted(by_id))})")
    m = by_id[mutant_id]
    root = tree or Path(cat.target.tree)
    files = snapshot(root)
    edits = [Edit(m.file, m.old, m.new)]
    sources = {f"{root.name}/{rel}": data for rel, data in edited(files, edits, what=f"{catalogue}: {m.id}").items()}
    sources.update(context(Path("."), cat.target.context, what=str(catalogue)))
    return MutantTree(m.id, m.effect, diff(files, edits, root.name), sources)


__all__ = ["MutantTree", "load_mutant"]
