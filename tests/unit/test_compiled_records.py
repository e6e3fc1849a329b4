"""The frozen records built every tick write their ``__init__`` out, and it stays the one
``@dataclass`` would have generated (docs/performance.md).

mypyc compiles the modules these records live in (`hil build`, hil/native), but not the methods the stdlib
``@dataclass`` decorator generates (mypyc/mypyc#817): a frozen dataclass's generated
``__init__`` runs interpreted, one ``object.__setattr__`` call at a time, about 15 times the
cost of the same body compiled. The records built on every 400 Hz tick therefore say
``@dataclass(frozen=True, init=False)`` and carry a hand-written ``__init__`` whose body is
``object.__setattr__(self, "field", field)`` per field.

Written by hand, that ``__init__`` can drift from the fields: a field added without its
parameter, two parameters swapped, a default lost or changed, ``frozen`` dropped with the
edit. Callers build these records positionally and by keyword, and the pickling helpers
(``hil.native.frozen.by_fields``, ``DeviceEvent.__reduce__``) rebuild them from their fields in
``dataclasses.fields()`` order, so any drift is a silent wrong value. These tests hold each
written-out ``__init__`` to the generated one, on the interpreted sources and on the
compiled build alike, and make sure a record written this way in the future joins the list.

The values passed in are typed (distinct ints, floats, strings, enum members, tuples of
them ...), not bare ``object()`` sentinels: compiled records check the types of their
fields, so an ``object()`` would be refused before the test got to read anything back.
The types come from the annotations as written in the source (``ast``): a compiled class's
``__annotations__`` keep only a coarse type object per field.
"""

from __future__ import annotations

import ast
import dataclasses
import enum
import functools
import inspect
import pickle
import sys
import types
import typing
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pytest

from emulators.buspirate.events import BusPirateSpi
from emulators.maestro.device import TargetsSet
from emulators.mcp3204.device import Mcp3204Conversion
from emulators.rc.ppm import PpmEdge, PpmFrame
from emulators.rc.sbus import PpmDecoded
from emulators.spidriver.device import SpiDriverSpi
from emulators.xbee.link import RfDelivered
from emulators.xbee.packets import RfPacket
from emulators.xsens.errors import Measured
from emulators.xsens.events import CommandHandled, SampleSent
from emulators.xsens.sample import Built, Ctx
from hil.analysis.timing_stream import LatencySample
from hil.plant.records import PlantState, SensorTruth
from hil.transport.base import WireRecord
from hil.vtime.control import ThreadView

ROOT = Path(__file__).resolve().parents[2]

#: Every frozen dataclass in a compiled module whose ``__init__`` is written out
#: (``init=False`` and an ``__init__`` of its own): the records built on every tick.
#: test_every_written_out_init_is_listed keeps this list complete.
RECORDS: list[type] = [
    # plant and tick path; WireRecord: the pty port's tap (hil/transport, compiled with the tick path)
    PlantState, SensorTruth, LatencySample, ThreadView, WireRecord,
    # XSENS: the sample as measured, the encoder's context and result, the event per message
    Measured, Ctx, Built, SampleSent, CommandHandled,
    # ADC behind the Bus Pirate (or the SPIDriver): a transfer and a conversion per tick
    BusPirateSpi, SpiDriverSpi, Mcp3204Conversion,
    # ESC commands through the Maestro
    TargetsSet,
    # RC: PPM edges and frames, the SBUS converter's decoded frames
    PpmEdge, PpmFrame, PpmDecoded,
    # telemetry radio
    RfPacket, RfDelivered,
]


def _name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _init_fields(cls: type) -> list[dataclasses.Field[Any]]:
    return [f for f in dataclasses.fields(cls) if f.init]


def _has_default(f: dataclasses.Field[Any]) -> bool:
    return f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING


# -- typed sample values ------------------------------------------------------------------------


@functools.cache
def _class_nodes(source: Path) -> dict[str, ast.ClassDef]:
    return {node.name: node for node in ast.parse(source.read_text(), filename=str(source)).body
            if isinstance(node, ast.ClassDef)}


def _written_annotations(cls: type) -> dict[str, tuple[str, dict[str, Any]]]:
    """Field name -> (its annotation as written in the source, the namespace of the module
    that wrote it), over ``cls`` and its bases, a subclass's own annotation winning."""
    found: dict[str, tuple[str, dict[str, Any]]] = {}
    for klass in reversed(cls.__mro__):
        module = sys.modules.get(klass.__module__)
        if module is None:
            continue
        # the project's sources, wherever the module was loaded from: a compiled build lives
        # in the environment (hil/native), not beside them
        source = ROOT.joinpath(*klass.__module__.split(".")).with_suffix(".py")
        node = _class_nodes(source).get(klass.__qualname__) if source.exists() else None
        for stmt in node.body if node is not None else []:
            if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
                found[stmt.target.id] = (ast.unparse(stmt.annotation), vars(module))
    return found


def _types(cls: type, names: Iterable[str]) -> dict[str, Any]:
    """Field name -> its type, for ``names``: the written annotation evaluated where it was
    written."""
    written = _written_annotations(cls)
    missing = [name for name in names if name not in written]
    assert not missing, f"{_name(cls)}: no annotation found in the source for {missing}"
    return {name: eval(written[name][0], written[name][1]) for name in names}


class _Values:
    """Distinct values of the types the records hold: every call gives a value unequal to
    the ones before it (bools aside: there are only two)."""

    def __init__(self) -> None:
        self._n = 0
        self._flip = False

    def _next(self) -> int:
        self._n += 1
        return 1000 + self._n

    def of(self, tp: Any, avoid: object = dataclasses.MISSING) -> object:
        """A value of type ``tp``; not ``avoid`` (a field's default) where the type allows."""
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if tp is None or tp is type(None):
            return None
        if origin in (types.UnionType, typing.Union):
            # the first arm that is not None: a default of None is never the value given
            return self.of(next(a for a in args if a is not type(None)), avoid)
        if origin is tuple:
            if len(args) == 2 and args[1] is Ellipsis:
                return (self.of(args[0]), self.of(args[0]))
            return tuple(self.of(a) for a in args)
        if tp is bool:
            if isinstance(avoid, bool):
                return not avoid
            self._flip = not self._flip
            return self._flip
        if tp is int:
            return self._next()
        if tp is float:
            return self._next() + 0.5
        if tp is str:
            return f"s{self._next()}"
        if tp is bytes:
            return b"b%d" % self._next()
        if isinstance(tp, type) and issubclass(tp, enum.Enum):
            members = [m for m in tp if m != avoid]
            return members[self._next() % len(members)]
        if isinstance(tp, type) and issubclass(tp, tuple) and hasattr(tp, "_fields"):  # NamedTuple
            named_tuple = typing.cast(Any, tp)
            hints = _types(tp, named_tuple._fields)
            return named_tuple(*[self.of(hints[name]) for name in named_tuple._fields])
        if isinstance(tp, type) and dataclasses.is_dataclass(tp):
            return tp(**sample(tp, self))
        raise AssertionError(f"no sample value for the type {tp!r}: teach tests/unit/test_compiled_records.py")


def sample(cls: type, values: _Values | None = None) -> dict[str, object]:
    """One value per ``__init__`` field of ``cls``, in ``dataclasses.fields()`` order, each
    unequal to the others and to the field's default. Bool fields without a default come
    last, taking the value the other bools have least, so that two of them differ."""
    values = _Values() if values is None else values
    hints = _types(cls, [f.name for f in _init_fields(cls)])
    out: dict[str, object] = {}
    later = []
    for f in _init_fields(cls):
        if hints[f.name] is bool and f.default is dataclasses.MISSING:
            later.append(f.name)
        else:
            out[f.name] = values.of(hints[f.name], f.default)
    for name in later:
        bools = [v for v in out.values() if isinstance(v, bool)]
        out[name] = bools.count(True) <= bools.count(False)
    return {f.name: out[f.name] for f in _init_fields(cls)}


# -- the records --------------------------------------------------------------------------------


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_init_is_written_out_and_frozen(cls: type) -> None:
    """``init=False`` and ``frozen=True``: the ``__init__`` is the hand-written, compiled one,
    and the record is still immutable (it is shared by the recorder, criteria and trace)."""
    params = cls.__dataclass_params__  # type: ignore[attr-defined]
    assert params.init is False, f"{_name(cls)}: @dataclass generates __init__ again (init=False lost)"
    assert params.frozen is True, f"{_name(cls)}: no longer frozen"
    assert "__init__" in vars(cls), f"{_name(cls)}: init=False but no __init__ of its own"


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_sample_values_are_distinct(cls: type) -> None:
    """The values the other tests pass are pairwise distinct (bools aside), so a value read
    back from the wrong field cannot pass by accident."""
    values = [v for v in sample(cls).values() if not isinstance(v, bool)]
    assert len({repr(v) for v in values}) == len(values)


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_positional_arguments_land_in_their_fields(cls: type) -> None:
    """Positional arguments in ``dataclasses.fields()`` order, as the tick path and
    ``by_fields`` unpickling pass them: each field reads back its own value."""
    values = sample(cls)
    record = cls(*values.values())
    for name, value in values.items():
        assert getattr(record, name) == value, f"{_name(cls)}.{name}"


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_keyword_arguments_land_in_their_fields(cls: type) -> None:
    """The same by keyword (``dataclasses.replace`` and callers naming fields): the
    parameters are named as the fields are."""
    values = sample(cls)
    record = cls(**dict(reversed(values.items())))
    for name, value in values.items():
        assert getattr(record, name) == value, f"{_name(cls)}.{name}"


@pytest.mark.parametrize("cls", [c for c in RECORDS if any(_has_default(f) for f in _init_fields(c))], ids=_name)
def test_defaults_are_the_fields_defaults(cls: type) -> None:
    """Built from its required fields only, a record has the fields' declared defaults; a
    ``default_factory`` gives a fresh, equal value per record, as the generated one does."""
    values = sample(cls)
    required = [values[f.name] for f in _init_fields(cls) if not _has_default(f)]
    first, second = cls(*required), cls(*required)
    for f in _init_fields(cls):
        if f.default is not dataclasses.MISSING:
            assert getattr(first, f.name) == f.default, f"{_name(cls)}.{f.name}"
            assert type(getattr(first, f.name)) is type(f.default), f"{_name(cls)}.{f.name}"
        elif f.default_factory is not dataclasses.MISSING:
            made = getattr(first, f.name)
            assert made == f.default_factory(), f"{_name(cls)}.{f.name}"
            if made.__hash__ is None:  # mutable: each record must have its own
                assert made is not getattr(second, f.name), f"{_name(cls)}.{f.name}: shared default_factory value"
        else:
            assert getattr(first, f.name) == values[f.name], f"{_name(cls)}.{f.name}"


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_fields_cannot_be_assigned(cls: type) -> None:
    """Writing the ``__init__`` out with ``object.__setattr__`` leaves the record frozen."""
    record = cls(*sample(cls).values())
    for f in dataclasses.fields(cls):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(record, f.name, getattr(record, f.name))


def _signature(cls: type) -> inspect.Signature | None:
    """``inspect.signature`` of the class, None where it cannot tell (a compiled class's text
    signature cannot carry every default) or tells nothing (``*args, **kwargs``)."""
    try:
        sig = inspect.signature(cls)
    except (TypeError, ValueError):
        return None
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return None if any(p.kind in variadic for p in sig.parameters.values()) else sig


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_parameters_are_the_init_fields(cls: type) -> None:
    """One parameter per ``__init__`` field, no more: a field added to the class without its
    parameter would otherwise be silently left unset. Where the signature can be read, the
    names, order, kinds, defaults and annotations are the ones ``@dataclass`` would generate."""
    init_fields = _init_fields(cls)
    values = sample(cls)
    with pytest.raises(TypeError):
        cls(*values.values(), next(iter(values.values())))
    required = [f for f in init_fields if not _has_default(f)]
    if required:
        with pytest.raises(TypeError):
            cls(*[values[f.name] for f in required[:-1]])

    sig = _signature(cls)
    if sig is None:
        return
    params = list(sig.parameters.values())
    assert [p.name for p in params] == [f.name for f in init_fields], _name(cls)
    written = {name: text for name, (text, _) in _written_annotations(cls).items()}
    for p, f in zip(params, init_fields, strict=True):
        assert p.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD, f"{_name(cls)}.{f.name}"
        if f.default is not dataclasses.MISSING:
            assert p.default == f.default and type(p.default) is type(f.default), f"{_name(cls)}.{f.name}"
        elif f.default_factory is not dataclasses.MISSING:
            assert p.default is not inspect.Parameter.empty, f"{_name(cls)}.{f.name}"
        else:
            assert p.default is inspect.Parameter.empty, f"{_name(cls)}.{f.name}"
        if isinstance(p.annotation, str):  # interpreted, ``from __future__ import annotations``
            assert p.annotation == written[f.name], f"{_name(cls)}.{f.name}"


@pytest.mark.parametrize("cls", [c for c in RECORDS if any("__reduce__" in vars(k) for k in c.__mro__[:-1])],
                         ids=_name)
def test_records_that_cross_processes_still_pickle(cls: type) -> None:
    """Records with a ``__reduce__`` (events and plant records go to the recorder's process,
    campaign results come back from workers) rebuild through the written-out ``__init__``."""
    record = cls(*sample(cls).values())
    assert pickle.loads(pickle.dumps(record)) == record


# -- the list is complete -------------------------------------------------------------------------


def _written_out(path: Path) -> Iterable[str]:
    """``module.Class`` of each class in ``path`` decorated ``@dataclass(..., init=False, ...)``
    that defines its own ``__init__`` (read from the source: nothing is imported)."""
    module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if not isinstance(node, ast.ClassDef):
            continue
        init_false = any(
            isinstance(d, ast.Call) and getattr(d.func, "id", getattr(d.func, "attr", "")) == "dataclass"
            and any(k.arg == "init" and isinstance(k.value, ast.Constant) and k.value.value is False for k in d.keywords)
            for d in node.decorator_list)
        if init_false and any(isinstance(b, ast.FunctionDef) and b.name == "__init__" for b in node.body):
            yield f"{module.removesuffix('.__init__')}.{node.name}"


def test_every_written_out_init_is_listed() -> None:
    """Every dataclass in ``hil`` and ``emulators`` with ``init=False`` and an ``__init__`` of its
    own is in RECORDS, so the next record written out this way is held to the generated
    ``__init__`` too; and every listed record is one of them."""
    found = {name for package in ("hil", "emulators") for path in sorted((ROOT / package).rglob("*.py"))
             for name in _written_out(path)}
    listed = {f"{c.__module__}.{c.__qualname__}" for c in RECORDS}
    missing = sorted(found - listed)
    assert not missing, f"add to RECORDS in {Path(__file__).name}: {missing}"
    extra = sorted(listed - found)
    assert not extra, f"listed in RECORDS but not a written-out __init__: {extra}"
