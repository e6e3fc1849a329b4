"""The control block's layout agrees between the C shim and its Python mirror."""

from __future__ import annotations

import ctypes

from hil.vtime import abi
from hil.vtime.preload import shim_library


def test_the_shim_and_the_python_mirror_agree_on_the_layout() -> None:
    library = shim_library()
    assert not hasattr(library, "reason"), library
    # Loading it here is inert: without HIL_VT_CTL the shim passes everything through,
    # and RTLD_LOCAL keeps its symbols from replacing this process's own.
    lib = ctypes.CDLL(str(library))
    expected = abi.expected_layout()
    exported = (ctypes.c_uint32 * len(expected)).in_dll(lib, "hvt_abi_layout")
    assert tuple(exported) == expected


def test_the_block_holds_the_header_and_every_slot() -> None:
    assert abi.BLOCK_SIZE == ctypes.sizeof(abi.Header) + abi.MAX_THREADS * ctypes.sizeof(abi.Slot)
    assert ctypes.sizeof(abi.Slot) % 64 == 0  # slots do not share cache lines


def _filled_slot(seed: int) -> abi.Slot:
    """A slot with a different value in every field (and every array element)."""
    s = abi.Slot()
    v = seed
    for name, ctype in abi.Slot._fields_:
        if hasattr(ctype, "_length_"):
            arr = getattr(s, name)
            for k in range(ctype._length_):
                v += 1
                arr[k] = v
        else:
            v += 1
            setattr(s, name, v)
    return s


def test_the_slot_record_reads_every_field_where_ctypes_has_it() -> None:
    assert abi.SLOT_STRUCT.size == ctypes.sizeof(abi.Slot)
    s = _filled_slot(1000)
    raw = abi.SLOT_STRUCT.unpack(bytes(s))
    assert raw[abi.SLOT_TID] == s.tid and raw[abi.SLOT_PID] == s.pid
    assert raw[abi.SLOT_STATE] == s.state and raw[abi.SLOT_SEQ] == s.seq
    assert raw[abi.SLOT_DEADLINE] == s.deadline_ns and raw[abi.SLOT_CPU] == s.cpu_ns
    assert raw[abi.SLOT_BLOCKS] == s.blocks
    assert raw[abi.SLOT_SEEN_EPOCH] == s.seen_epoch and raw[abi.SLOT_NKEYS] == s.nkeys
    assert raw[abi.SLOT_KEY_RDEV : abi.SLOT_KEY_RDEV + abi.MAX_KEYS] == tuple(s.key_rdev)
    assert raw[abi.SLOT_KEY_EVENTS : abi.SLOT_KEY_EVENTS + abi.MAX_KEYS] == tuple(s.key_events)
    assert raw[abi.SLOT_SPIN_YIELDS] == s.spin_yields
    assert raw[abi.SLOT_CLOCK_READS] == s.clock_reads and raw[abi.SLOT_WAIT_KIND] == s.wait_kind
    assert raw[-2:] == tuple(s.reserved)
