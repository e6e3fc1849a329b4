"""The zstd level of the recorder's MCAP chunks: ``mcap.writer``'s zstandard, patched once.

Imported (and so executed once) by ``hil.record.writer``: every MCAP file written in this
process, the recorder's and ``hil recover``'s, gets chunks at ``ZSTD_LEVEL``.
"""

from __future__ import annotations

from typing import Any

import mcap.writer as _mcap_writer

#: zstd level of the chunks. mcap-python compresses with zstandard's default (3) and has no
#: option; level 6 makes a run's file 4 % smaller for +0.2 ms per 64 KiB chunk, on the
#: recorder's own process (measured on a 48 s mission: 5.88 -> 5.66 MB of chunks; level 15
#: gains 5 % more at 10x the CPU).
ZSTD_LEVEL = 6


class _LeveledZstd:
    """Stands in for the ``zstandard`` module inside ``mcap.writer`` (it only calls
    ``compress``): the same function at ``ZSTD_LEVEL``. Thread-safe (no shared compressor)."""

    def __init__(self, module: Any) -> None:
        self._module = module

    def compress(self, data: bytes) -> bytes:
        return self._module.compress(data, ZSTD_LEVEL)  # type: ignore[no-any-return]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._module, name)


if getattr(_mcap_writer, "zstandard", None) is not None and not isinstance(_mcap_writer.zstandard, _LeveledZstd):
    _mcap_writer.zstandard = _LeveledZstd(_mcap_writer.zstandard)  # type: ignore[assignment]


__all__ = ["ZSTD_LEVEL"]
