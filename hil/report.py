"""``hil report``: PNG plots of a run from its MCAP log (matplotlib, Agg backend).

Four figures: attitude (truth and, when telemetry carries them, the flight code's
references), altitude (truth, estimate, reference), motors (ESC commands and throttles),
and timing (IMU emit -> ESC command latency per tick and its histogram).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _get(arrays: dict[str, np.ndarray], *names: str) -> np.ndarray | None:
    for name in names:
        if name in arrays and arrays[name].size:
            return arrays[name]
    return None


def make_report(log: Path, out_dir: Path) -> list[Path]:
    """Write the run's PNG plots into ``out_dir``; returns their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hil.record import read_metadata, read_topic

    out_dir.mkdir(parents=True, exist_ok=True)
    stem = log.name.removesuffix(".mcap")
    meta = read_metadata(log).get("run", {})
    title = f"{meta.get('rig', '?')} / {meta.get('scenario', '?')} / seed {meta.get('seed', '?')}"
    truth = read_topic(log, "/sim/truth")
    tm = read_topic(log, "/fc/telemetry")
    t0 = truth["log_time_ns"][0] if truth.get("log_time_ns") is not None and truth["log_time_ns"].size else 0
    t = (truth["log_time_ns"] - t0) / 1e9 if truth.get("log_time_ns") is not None else np.zeros(0)
    t_tm = (tm["log_time_ns"] - t0) / 1e9 if tm.get("log_time_ns") is not None and tm["log_time_ns"].size else None
    paths: list[Path] = []

    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 8))
    for ax, axis in zip(axes, ("roll", "pitch", "yaw"), strict=True):
        v = _get(truth, f"euler_deg.{axis}")
        if v is not None:
            ax.plot(t, v, label=f"{axis} truth")
        ref = _get(tm, f"{axis}_ref_deg", f"ref_{axis}_deg")
        if ref is not None and t_tm is not None:
            ax.plot(t_tm, ref, "--", label=f"{axis} reference (telemetry)")
        ax.set_ylabel("deg")
        ax.legend(loc="upper right")
        ax.grid(True)
    axes[0].set_title(f"attitude - {title}")
    axes[-1].set_xlabel("sim time [s]")
    paths.append(_save(fig, out_dir / f"{stem}_attitude.png"))

    fig, ax = plt.subplots(figsize=(10, 4))
    h = _get(truth, "h_m")
    if h is not None:
        ax.plot(t, h, label="altitude truth")
    if t_tm is not None:
        for key, style, label in (("alt_est_m", "-", "estimate"), ("alt_ref_m", "--", "reference")):
            v = _get(tm, key, key.replace("alt_", "z_"))
            if v is not None:
                ax.plot(t_tm, v, style, label=f"altitude {label} (telemetry)")
    ax.set_ylabel("m")
    ax.set_xlabel("sim time [s]")
    ax.set_title(f"altitude - {title}")
    ax.grid(True)
    ax.legend()
    paths.append(_save(fig, out_dir / f"{stem}_altitude.png"))

    cmd = read_topic(log, "/hil/esc/command")
    out = read_topic(log, "/hil/esc/output")
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
    targets = _get(cmd, "targets_us")
    if targets is not None:
        tc = (cmd["log_time_ns"] - t0) / 1e9
        for i in range(targets.shape[1]):
            axes[0].plot(tc, targets[:, i], lw=0.8, label=f"motor {i}")
    axes[0].set_ylabel("ESC command [us]")
    axes[0].legend(loc="upper right")
    thr = _get(out, "throttle")
    if thr is not None:
        to = (out["log_time_ns"] - t0) / 1e9
        for i in range(thr.shape[1]):
            axes[1].plot(to, thr[:, i], lw=0.8, label=f"motor {i}")
    axes[1].set_ylabel("throttle seen by the ESC")
    axes[1].set_xlabel("sim time [s]")
    axes[0].set_title(f"motors - {title}")
    for ax in axes:
        ax.grid(True)
    paths.append(_save(fig, out_dir / f"{stem}_motors.png"))

    from hil.timing import plot_latency

    timing_png = plot_latency(log, out_dir / f"{stem}_timing.png")
    if timing_png is not None:
        paths.append(timing_png)
    return paths


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()  # type: ignore[attr-defined]
    fig.savefig(path, dpi=110)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path
