"""The write log a pty group shares with the virtual-time scheduler."""

from __future__ import annotations

from pathlib import Path

from hil.transport.pty import PtyPort, WriteLog


def test_the_log_counts_every_write_and_names_the_ports_written(tmp_path: Path) -> None:
    a, b, c = (PtyPort(n, tmp_path) for n in ("a", "b", "c"))
    try:
        log = WriteLog()
        for p in (a, b, c):
            p.write_log = log
        assert log.take() == set() and log.count == 0
        a.write(b"x")
        a.write(b"y")
        c.write(b"z")
        b.write(b"")  # nothing written: not a write
        assert log.count == 3
        assert log.take() == {a, c}
        assert log.take() == set()  # taken: none since
        b.write(b"w")
        assert log.take() == {b} and log.count == 4
    finally:
        for p in (a, b, c):
            p.close()
