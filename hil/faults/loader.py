"""Scenario ``[[faults]]`` entries -> validated :class:`ScheduledFault` records, or a clear refusal.

An entry is a flat table: the envelope keys ``kind``, ``t_s`` (sim time, s) and
``duration_s`` (per the kind's timing), the rest are the kind's parameters::

    [[faults]]
    kind = "wire.bit_flips"
    t_s = 12.0
    duration_s = 2.0
    port = "imu"
    bit_error_rate = 1e-4

Everything wrong is refused here, never at run time: an unknown kind or key, a bad value,
a duration the kind does not take, and anything the rig cannot do (a port it does not
have, a channel its receiver does not send, a checksum its protocol does not carry...).
Each problem is one line ``<file>: [[faults]] #<index> (<kind>) <key>: <reason>``; all of
them are raised together as one :class:`hil.config.ConfigError`.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from typing import Any

import pydantic

from hil.config import ConfigError
from hil.faults.base import Refused, ScheduledFault, Timing
from hil.faults.catalogue import CATALOGUE

ENVELOPE = ("kind", "t_s", "duration_s")


class _Problems(Exception):
    def __init__(self, lines: list[str]) -> None:
        super().__init__("\n".join(lines))
        self.lines = lines


def load_faults(
    entries: Sequence[Mapping[str, Any]],
    rig: Any,
    *,
    source: str,
    run_duration_s: float | None = None,
) -> list[ScheduledFault]:
    """Validate a scenario's ``[[faults]]`` list for ``rig``; ``source`` names the file in
    messages. With ``run_duration_s`` a fault starting after the run's end is refused too."""
    out: list[ScheduledFault] = []
    lines: list[str] = []
    for i, raw in enumerate(entries):
        try:
            out.append(make_fault(raw, rig, source=source, index=i, run_duration_s=run_duration_s))
        except _Problems as exc:
            lines.extend(exc.lines)
    if lines:
        raise ConfigError("\n".join(lines))
    return out


def check_fault(raw: Mapping[str, Any], rig: Any, *, source: str, index: int | None = None,
                run_duration_s: float | None = None) -> ScheduledFault:
    """One entry, raising :class:`ConfigError` (for programmatic faults)."""
    try:
        return make_fault(raw, rig, source=source, index=index, run_duration_s=run_duration_s)
    except _Problems as exc:
        raise ConfigError("\n".join(exc.lines)) from None


def make_fault(raw: Any, rig: Any, *, source: str, index: int | None,
               run_duration_s: float | None = None) -> ScheduledFault:
    where = f"{source}: [[faults]] #{index}" if index is not None else f"{source}:"
    if not isinstance(raw, Mapping):
        raise _Problems([f"{where}: must be a table (got {raw!r})"])
    kind = raw.get("kind")
    if kind is None:
        raise _Problems([f"{where} kind: missing (see `hil faults` for the catalogue)"])
    cls = CATALOGUE.get(kind) if isinstance(kind, str) else None
    if cls is None:
        close = difflib.get_close_matches(str(kind), list(CATALOGUE), n=3)
        hint = f"did you mean {', '.join(close)}?" if close else "see `hil faults` for the catalogue"
        raise _Problems([f"{where} kind: unknown fault kind {kind!r} ({hint})"])
    where = f"{where} ({kind})"
    problems: list[str] = []

    t_s = raw.get("t_s")
    if t_s is None:
        problems.append(f"{where} t_s: missing (start time, s of sim time)")
    elif isinstance(t_s, bool) or not isinstance(t_s, (int, float)) or not math.isfinite(t_s) or t_s < 0:
        problems.append(f"{where} t_s: must be a number >= 0 (got {t_s!r})")
    elif run_duration_s is not None and t_s >= run_duration_s:
        problems.append(f"{where} t_s: {t_s:g} s is not before the end of the run ({run_duration_s:g} s)")

    duration = raw.get("duration_s")
    if duration is not None and (
        isinstance(duration, bool) or not isinstance(duration, (int, float)) or not math.isfinite(duration) or duration <= 0
    ):
        problems.append(f"{where} duration_s: must be a number > 0 (got {duration!r})")
    elif cls.timing is Timing.INSTANT and duration is not None:
        problems.append(f"{where} duration_s: {kind} is one action at t_s and takes no duration")
    elif cls.timing is Timing.BOUNDED and duration is None:
        problems.append(f"{where} duration_s: missing ({kind} needs a duration)")

    params_raw = {k: v for k, v in raw.items() if k not in ENVELOPE}
    params = None
    try:
        params = cls.Params.model_validate(params_raw)
    except pydantic.ValidationError as exc:
        for err in exc.errors():
            key = ".".join(str(p) for p in err["loc"]) or "(parameters)"
            got = err.get("input")
            shown = "" if isinstance(got, Mapping) else f" (got {got!r})"
            msg = err["msg"]
            if err["type"] == "extra_forbidden":
                known = ", ".join(cls.Params.model_fields) or "none"
                msg = f"unknown parameter of {kind} (its parameters: {known})"
            problems.append(f"{where} {key}: {msg}{shown}")
    if params is not None:
        try:
            cls.check(params, rig)
        except Refused as exc:
            problems.append(f"{where} {exc.key}: {exc.reason}")
    if problems:
        raise _Problems(problems)
    assert params is not None and t_s is not None
    return ScheduledFault(
        kind=kind,
        t_s=float(t_s),
        duration_s=None if duration is None else float(duration),
        params=params,
        target=cls.target_of(params),
        index=index,
        source=source,
    )
