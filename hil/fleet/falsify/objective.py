"""The number ``hil falsify`` drives below zero: a flight's lowest criterion margin, each margin
scaled to its criterion's own bounds so that metres, degrees and shares compare.

| criterion | scale |
|---|---|
| bounded both sides (``min`` and ``max``) | half the band, (max - min) / 2 |
| one bound, not zero | that bound's magnitude |
| one bound at zero | 1 (the metric's unit) |

A criterion that passes with a margin of exactly 0 cannot pass by more: a share that must be
all (``min = 1``) or none (``max = 0``), a reported mode, the minimum pulse the watchdog
commands (``max = 1000`` us, which it sends exactly). Those count only when they fail, else
they would pin the lowest margin at 0 in every flight and hide the criteria that can move. A flight that did not complete (the flight code crashed, the bench stopped it) or a
criterion without a value (an empty window) is a failure beyond any margin: :data:`FAILED`.

A search may be aimed at some criteria (``hil falsify --criterion TEXT``, :func:`focused`): then
only theirs count, both for the lowest margin and for a failure. A mutant usually moves one
claim, and the lowest margin of all criteria often follows another that it does not touch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from hil.config.scenario import Criterion

#: the objective of a flight that failed without a margin (did not complete, no value)
FAILED = -1e6


def scale(c: Criterion) -> float:
    """A criterion's margin unit for comparing with others (module docstring)."""
    if c.min is not None and c.max is not None and c.max > c.min:
        return (c.max - c.min) / 2
    bound = c.min if c.min is not None else c.max
    return abs(bound) if bound else 1.0


def focused(name: str, focus: Sequence[str]) -> bool:
    """Whether criterion ``name`` counts under ``focus`` (texts any of which it contains,
    case-insensitive; no focus: every criterion counts)."""
    return not focus or any(f.lower() in name.lower() for f in focus)


def robustness(result: Mapping[str, Any], criteria: Mapping[str, Criterion],
               focus: Sequence[str] = ()) -> tuple[float, str]:
    """(the flight's lowest scaled margin, the criterion that set it) from a campaign result
    (hil/fleet/campaign_case.py: ``criteria`` with ``margin``, null when it has none), over the
    criteria ``focus`` names (:func:`focused`). A flight that did not complete fails whatever
    the focus."""
    if result.get("end_reason") != "completed":
        return FAILED, f"the flight ended: {result.get('end_reason')} ({result.get('message', '')})"
    lowest, name = math.inf, ""
    for r in result.get("criteria", []):
        if not focused(r["name"], focus):
            continue
        margin, passed = r.get("margin"), bool(r.get("passed"))
        c = criteria.get(r["name"])
        if margin is None:
            value = math.inf if passed else FAILED
        elif c is None:  # the bench's own (timing, board): in its own unit
            value = float(margin)
        elif passed and margin == 0.0:  # a share that must be all or none passes only at 0
            value = math.inf  # at its limit by design: no nearer to failing in one flight than another
        else:
            value = float(margin) / scale(c)
        if not passed:
            value = min(value, -1e-9)  # a failure is below zero even at a margin of -0.0
        if value < lowest:
            lowest, name = value, r["name"]
    return min(lowest, -FAILED), name  # bounded: the optimiser compares, and inf has no spread


__all__ = ["FAILED", "focused", "robustness", "scale"]
