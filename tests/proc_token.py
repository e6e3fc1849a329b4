"""The processes a flight command started, found as the tests' own oracle: every live process in
/proc whose environment carries the bench's tree token (hil/flight/process_tree.py), whoever its
parent or session now is. Independent of the bench's own tree tracking, which it checks."""

from __future__ import annotations

import os

from hil.flight.process_tree import TOKEN_ENV
from hil.vtime.tree import read_stat


def with_token(token_prefix: str) -> list[tuple[int, str]]:
    """(pid, comm) of each live process whose ``HIL_FLIGHT_TREE`` value starts with
    ``token_prefix`` (a whole token, or ``f"{bench_pid}-"`` for every flight of one bench)."""
    mark = f"{TOKEN_ENV}={token_prefix}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as f:
                env = f.read().split(b"\0")
        except OSError:
            continue
        st = read_stat(int(entry))
        if st is not None and not st.dead and any(v.startswith(mark) for v in env):
            found.append((int(entry), st.comm))
    return found
