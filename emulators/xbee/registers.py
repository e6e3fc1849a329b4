"""The AT parameters of the 802.15.4 module: sizes, ranges, and their values.

Values are numbers (big-endian of the register's width in API responses, upper-case hex
without leading zeros in command mode) except NI (a string). Set values are "pending"
until applied (``AC``, ``CN``, an 0x08 frame), as on the module.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import Enum, auto

from emulators.xbee.params import XBeeParams


class RegKind(Enum):
    """What a two-letter command is."""

    NUMBER = auto()
    STRING = auto()
    EXEC = auto()  # an action (WR, AC, CN, FR, RE)


@dataclass(frozen=True)
class RegSpec:
    """``width`` bytes in API responses; ``writable``; accepted range ``lo``..``hi``."""

    kind: RegKind
    width: int = 0
    writable: bool = True
    lo: int = 0
    hi: int = 0


def _n(width: int, lo: int = 0, hi: int | None = None, writable: bool = True) -> RegSpec:
    return RegSpec(RegKind.NUMBER, width, writable, lo, (1 << (8 * width)) - 1 if hi is None else hi)


#: Parameter table (Digi 802.15.4 product manual; widths of read-only identity registers as
#: digi-xbee reads them: HV first byte = hardware family, SH/SL 4 bytes each, MY 2 bytes).
REGISTERS: dict[str, RegSpec] = {
    "AP": _n(1, 0, 2),
    "BD": _n(4, 0, 0x1C9C380),
    "CH": _n(1, 0x0C, 0x17),
    "ID": _n(2),
    "MY": _n(2),
    "DH": _n(4),
    "DL": _n(4),
    "SH": _n(4, writable=False),
    "SL": _n(4, writable=False),
    "NI": RegSpec(RegKind.STRING, 20),
    "CE": _n(1, 0, 1),
    "HV": _n(2, writable=False),
    "VR": _n(2, writable=False),
    "RO": _n(1),
    "GT": _n(2, 2, 0x0CE4),
    "CC": _n(1),
    "CT": _n(2, 2, 0xFFFF),
    "RR": _n(1, 0, 6),
    "MM": _n(1, 0, 3),
    "PL": _n(1, 0, 4),
    "AI": _n(1, writable=False),
    "DB": _n(1, writable=False),
    "NP": _n(2, writable=False),
    "EA": _n(2, writable=False),
    "EC": _n(2, writable=False),
    "WR": RegSpec(RegKind.EXEC),
    "AC": RegSpec(RegKind.EXEC),
    "CN": RegSpec(RegKind.EXEC),
    "FR": RegSpec(RegKind.EXEC),
    "RE": RegSpec(RegKind.EXEC),
}

#: Register name -> XBeeParams field it starts from.
_FROM_PARAMS = {
    "AP": "ap", "BD": "bd", "CH": "ch", "ID": "pan_id", "MY": "my", "DH": "dh", "DL": "dl", "SH": "sh",
    "SL": "sl", "NI": "ni", "CE": "ce", "HV": "hv", "VR": "vr", "RO": "ro", "GT": "gt_ms", "CC": "cc",
    "CT": "ct_100ms", "RR": "rr", "MM": "mm", "PL": "pl", "NP": "max_payload",
}
assert set(_FROM_PARAMS.values()) <= {f.name for f in fields(XBeeParams)}


class Registers:
    """Current (applied) and pending values of one module."""

    def __init__(self, params: XBeeParams) -> None:
        self.defaults = params
        self.values: dict[str, int | str] = {}
        self.pending: dict[str, int | str] = {}
        self.restore_defaults()

    def restore_defaults(self) -> None:
        """RE: factory values (the rig's params)."""
        self.values = {name: getattr(self.defaults, attr) for name, attr in _FROM_PARAMS.items()}
        self.values.update(AI=0, DB=0, EA=0, EC=0)
        self.pending.clear()

    def get(self, name: str) -> int | str:
        """Current value (pending ones are not visible until applied, like the module)."""
        return self.values[name]

    def num(self, name: str) -> int:
        """Current numeric value."""
        value = self.values[name]
        assert isinstance(value, int)
        return value

    def validate(self, name: str, value: int | str) -> bool:
        """True if ``value`` is acceptable for ``name``."""
        spec = REGISTERS[name]
        if not spec.writable or spec.kind is RegKind.EXEC:
            return False
        if spec.kind is RegKind.STRING:
            return isinstance(value, str) and len(value) <= spec.width
        return isinstance(value, int) and spec.lo <= value <= spec.hi

    def stage(self, name: str, value: int | str) -> None:
        """Queue a validated value until :meth:`apply`."""
        self.pending[name] = value

    def apply(self) -> set[str]:
        """Apply pending values; returns the names that changed."""
        changed = {k for k, v in self.pending.items() if self.values.get(k) != v}
        self.values.update(self.pending)
        self.pending.clear()
        return changed

    def encode_api(self, name: str) -> bytes:
        """The value as an API response carries it."""
        spec = REGISTERS[name]
        value = self.values[name]
        if spec.kind is RegKind.STRING:
            return str(value).encode("ascii", "replace")
        assert isinstance(value, int)
        return value.to_bytes(spec.width, "big")

    def encode_text(self, name: str) -> str:
        """The value as command mode prints it (upper-case hex, no leading zeros)."""
        value = self.values[name]
        return value if isinstance(value, str) else f"{value:X}"

    @staticmethod
    def decode_api(name: str, param: bytes) -> int | str | None:
        """An API parameter as a value (None if malformed)."""
        spec = REGISTERS[name]
        if spec.kind is RegKind.STRING:
            try:
                return param.decode("ascii")
            except UnicodeDecodeError:
                return None
        if len(param) > max(spec.width, 1) and any(param[: len(param) - spec.width]):
            return None
        return int.from_bytes(param, "big")

    @staticmethod
    def decode_text(name: str, text: str) -> int | str | None:
        """A command-mode parameter as a value (None if malformed)."""
        if REGISTERS[name].kind is RegKind.STRING:
            return text
        try:
            return int(text.strip(), 16)
        except ValueError:
            return None
