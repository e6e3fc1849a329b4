"""Case functions for the campaign tests. Module level, so the executors can pickle them by
reference and spawned workers can import them."""

from __future__ import annotations

import os
from typing import Any

from hil.fleet.campaign import run_bundled_case
from hil.fleet.campaign_executors import failure

DIE_SEED = 13


def fake_pass(params: dict[str, Any]) -> dict[str, Any]:
    """A passing result without flying (executor mechanics only)."""
    result = failure(params, "completed", "")
    return result | {"passed": True, "wall_s": 0.0,
                     "criteria": [{"name": "c", "signal": "s", "metric": "max_abs", "value": float(params["seed"]),
                                   "bound": "<= 100", "passed": True, "margin": 100.0 - float(params["seed"]),
                                   "detail": ""}]}


def die_on_seed_13(params: dict[str, Any]) -> dict[str, Any]:
    """Kills its own worker process for seed 13 (as a segfault in the worker would)."""
    if params["seed"] == DIE_SEED:
        os._exit(3)
    return fake_pass(params)


def first_fake_then_real(params: dict[str, Any]) -> dict[str, Any]:
    """Seed 1 passes at once (so the test can stop the campaign while seed 2 really flies)."""
    return fake_pass(params) if params["seed"] == 1 else run_bundled_case(params)


def first_fake_then_real_blind(params: dict[str, Any]) -> dict[str, Any]:
    """As :func:`first_fake_then_real`, on a worker that cannot see the campaign's STOP file
    (another machine): a stop reaches it only through the Dask event."""
    return fake_pass(params) if params["seed"] == 1 else run_bundled_case({**params, "stop_file": None})
