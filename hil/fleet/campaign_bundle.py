"""A campaign case as bytes, both ways: workers share no filesystem with the client.

Client side, :func:`case_files` gathers what a case's loaders read (the rig, the flight-config
template the rig names, the scenario) and what the rig's flight command names by relative
path (a script, a binary), as ``relative path -> (mode, bytes)``. On the worker,
:func:`materialize` writes them under a temporary directory; after the case,
:func:`pack_result` puts into the result the bytes of the log the case kept and of a failed
case's directory, and on the client :func:`land_result` writes those into the campaign's own
``logs/`` and ``cases/<id>/`` and leaves paths in their place.

Layout under the case's directory (``files/``):

* ``config/``: the rig and its template at their places relative to the nearest directory
  holding both, so the rig's relative ``[flight] config`` (``../x.toml`` too) finds its
  template unchanged. An absolute ``config`` is rewritten to the shipped copy.
* ``scenario/<file name>``: the scenario.
* ``work/``: the flight command's working directory, with the files its arguments name
  relative to the directory the campaign was started in.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path, PurePosixPath
from typing import Any

import tomli_w

from hil.config import ConfigError, load_toml
from hil.fleet.campaign_case import nested

#: relative path -> (file mode bits, content)
Files = dict[str, tuple[int, bytes]]
CONFIG_DIR, SCENARIO_DIR, WORK_DIR = "config", "scenario", "work"


def _entry(path: Path) -> tuple[int, bytes]:
    return stat.S_IMODE(path.stat().st_mode), path.read_bytes()


def _effective_flight(rig_path: Path, rig_overrides: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """The rig's data and its ``[flight]`` table with the case's overrides merged in."""
    from hil.flight.run_files import deep_merge

    data = load_toml(rig_path)
    merged = deep_merge(data, nested(rig_overrides)) if rig_overrides else data
    return data, dict(merged.get("flight", {}))


def rig_files(rig_path: Path, rig_overrides: dict[str, Any], cwd: Path) -> tuple[Files, str]:
    """The rig, its template and the command's files; returns (files, the rig's relative path)."""
    data, flight = _effective_flight(rig_path, rig_overrides)
    config = Path(str(flight.get("config", "flightcode-paper-quad.toml")))
    rig_dir = rig_path.parent.resolve()
    template = (rig_dir / config).resolve()
    if not template.is_file():
        raise ConfigError(f"{rig_path}: [flight] config: {template} does not exist")
    base = Path(os.path.commonpath([rig_dir, template.parent]))
    rig_rel = (rig_dir / rig_path.name).relative_to(base).as_posix()
    template_rel = template.relative_to(base).as_posix()
    files: Files = {f"{CONFIG_DIR}/{template_rel}": _entry(template)}
    mode, rig_bytes = _entry(rig_path)
    if config.is_absolute() and "config" in data.get("flight", {}):
        # the worker has its own filesystem: point the rig at the shipped copy
        data = dict(data)
        data["flight"] = {**data["flight"], "config": os.path.relpath(template, rig_dir)}
        rig_bytes = tomli_w.dumps(data).encode()
    files[f"{CONFIG_DIR}/{rig_rel}"] = (mode, rig_bytes)
    for arg in flight.get("command", ()):
        arg = str(arg)
        if "{" in arg or os.path.isabs(arg) or not (cwd / arg).is_file():
            continue  # placeholders, programs on the worker's own PATH or disk, options
        rel = PurePosixPath(os.path.normpath(arg))
        if rel.parts and rel.parts[0] != "..":
            files[f"{WORK_DIR}/{rel}"] = _entry(cwd / arg)
    return files, f"{CONFIG_DIR}/{rig_rel}"


def scenario_files(scenario_path: Path) -> tuple[Files, str]:
    rel = f"{SCENARIO_DIR}/{scenario_path.name}"
    return {rel: _entry(scenario_path)}, rel


def _safe(root: Path, rel: str) -> Path:
    """``root / rel``, refusing a path that would leave ``root``."""
    parts = PurePosixPath(rel).parts
    if not parts or PurePosixPath(rel).is_absolute() or ".." in parts:
        raise ValueError(f"a shipped file has an unsafe path: {rel!r}")
    return root.joinpath(*parts)


def materialize(files: Files, root: Path) -> None:
    """Write ``files`` under ``root`` (created), with their modes."""
    root.mkdir(parents=True, exist_ok=True)
    (root / WORK_DIR).mkdir(exist_ok=True)
    for rel, (mode, data) in files.items():
        p = _safe(root, rel)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
        p.chmod(mode & 0o777)


def pack_result(result: dict[str, Any]) -> dict[str, Any]:
    """Worker side: the result with the kept log's bytes and, for a failed case, its
    directory's files (``log_file``, ``case_files``) in place of worker paths."""
    out = dict(result)
    log = out.pop("log", None)
    out["log"] = None
    if log and Path(log).is_file():
        out["log_file"] = {"name": Path(log).name, "bytes": Path(log).read_bytes()}
    case_dir = out.pop("case_dir", None)
    if case_dir and Path(case_dir).is_dir():
        out["case_files"] = {p.relative_to(case_dir).as_posix(): p.read_bytes()
                             for p in sorted(Path(case_dir).rglob("*")) if p.is_file()}
    return out


def land_result(result: dict[str, Any], campaign_dir: Path) -> dict[str, Any]:
    """Client side: write a packed result's log into ``campaign_dir/logs/`` and a failed
    case's files into ``campaign_dir/cases/<case id>/``; ``log``/``case_dir`` name them."""
    out = dict(result)
    log_file = out.pop("log_file", None)
    if log_file is not None:
        logs = campaign_dir / "logs"
        logs.mkdir(exist_ok=True)
        path = _safe(logs, log_file["name"])
        with path.open("xb") as f:  # never over another case's log
            f.write(log_file["bytes"])
        out["log"] = str(path)
    case_files = out.pop("case_files", None)
    if case_files is not None:
        case_dir = campaign_dir / "cases" / out["case_id"]
        for rel, data in case_files.items():
            p = _safe(case_dir, rel)
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
        out["case_dir"] = str(case_dir)
    return out


__all__ = ["Files", "land_result", "materialize", "pack_result", "rig_files", "scenario_files"]
