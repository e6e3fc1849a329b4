"""The error of a recorded log that cannot be replayed or re-run as asked.

Its own module because both hil/fleet/replay.py (replay on ptys) and hil/fleet/verify.py
(re-run and compare) raise it, and replay.py re-exports verify's names: neither imports the other's
error without a cycle.
"""

from __future__ import annotations


class ReplayError(ValueError):
    """The log cannot be replayed as asked (unknown port, bad speed, no recorded bytes), or
    re-run (not a bench run log, an attachment missing)."""


__all__ = ["ReplayError"]
