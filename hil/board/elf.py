"""The firmware image: an ARM ELF's loadable segments at their load addresses, and its symbols
(pyelftools)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from elftools.elf.constants import P_FLAGS
from elftools.elf.elffile import ELFFile
from elftools.elf.sections import SymbolTableSection

from hil.board.errors import FirmwareError

EM_ARM = "EM_ARM"


@dataclass(frozen=True)
class Segment:
    """Bytes to place at ``address`` (the load address: .data's initial values sit in flash,
    where the startup code copies them from)."""

    address: int
    data: bytes
    executable: bool


@dataclass(frozen=True)
class FirmwareImage:
    path: Path
    entry: int
    segments: tuple[Segment, ...]
    symbols: dict[str, int]

    def symbol(self, name: str) -> int:
        try:
            return self.symbols[name]
        except KeyError:
            raise FirmwareError(f"{self.path}: no symbol {name!r}") from None


def load_elf(path: Path) -> FirmwareImage:
    """Read ``path``; a clear :class:`FirmwareError` names the file and what is wrong with it."""
    try:
        with path.open("rb") as f:
            elf = ELFFile(f)
            if elf["e_machine"] != EM_ARM or elf.elfclass != 32 or not elf.little_endian:
                raise FirmwareError(f"{path}: not a 32-bit little-endian ARM ELF ({elf['e_machine']})")
            segments = []
            for seg in elf.iter_segments():
                if seg["p_type"] != "PT_LOAD" or seg["p_filesz"] == 0:
                    continue
                segments.append(Segment(seg["p_paddr"], seg.data()[:seg["p_filesz"]],
                                        bool(seg["p_flags"] & P_FLAGS.PF_X)))
            symbols: dict[str, int] = {}
            for section in elf.iter_sections():
                if isinstance(section, SymbolTableSection):
                    for sym in section.iter_symbols():
                        if sym.name and not sym.name.startswith("$") and sym["st_shndx"] != "SHN_UNDEF":
                            symbols.setdefault(sym.name, sym["st_value"])
            entry = elf["e_entry"]
    except OSError as e:
        raise FirmwareError(f"{path}: cannot read the firmware: {e.strerror or e}") from e
    except Exception as e:  # pyelftools raises its own ELFError and struct errors on garbage
        if isinstance(e, FirmwareError):
            raise
        raise FirmwareError(f"{path}: not a readable ELF file ({e})") from e
    if not segments:
        raise FirmwareError(f"{path}: no loadable segment")
    return FirmwareImage(path, entry, tuple(segments), symbols)
