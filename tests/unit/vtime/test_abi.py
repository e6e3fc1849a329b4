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
