"""``hil report``: PNG plots of a run from its MCAP log (matplotlib, Agg backend).

Four figures: attitude (truth and, when telemetry carries them, the flight code's
references), altitude (truth, estimate, reference), motors (ESC commands and throttles),
and timing (IMU emit -> ESC command latency per tick and its histogram).

Files are ``<log stem>_{attitude,altitude,motors,report-timing}.png``: the timing figure
has its own name so that it never replaces ``hil timing``'s ``<log stem>_timing.png``
(which may use another budget). Legends sit outside the axes, so they never hide data;
each motor has its own colour and line style, so the four can be told apart in print too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _get(arrays: dict[str, np.ndarray], *names: str) -> np.ndarray | None:
    for name in names:
        if name in arrays and arrays[name].size:
            return arrays[name]
    return None


#: (colour, line style) per motor index: distinct in colour and in black-and-white print
MOTOR_STYLES = (("tab:blue", "-"), ("tab:orange", "--"), ("tab:green", "-."), ("tab:red", ":"))
TIMING_SUFFIX = "_report-timing.png"


def _legend_outside(ax: object) -> None:
    """Legend to the right of the axes (never over the data); nothing if no labels."""
    handles, _ = ax.get_legend_handles_labels()  # type: ignore[attr-defined]
    if handles:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small")  # type: ignore[attr-defined]


def make_report(log: Path, out_dir: Path) -> list[Path]:
    """Write the run's PNG plots into ``out_dir``; returns their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = log.name.removesuffix(".mcap")
    paths = [_save(fig, out_dir / f"{stem}_{name}.png") for name, fig in figures(log)]
    from hil.analysis.timing import plot_latency

    timing_png = plot_latency(log, out_dir / f"{stem}{TIMING_SUFFIX}")
    if timing_png is not None:
        paths.append(timing_png)
    return paths


def figures(log: Path) -> list[tuple[str, object]]:
    """The attitude, altitude and motors figures of a run, as (name, matplotlib figure)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hil.record import read_metadata, read_topic

    meta = read_metadata(log).get("run", {})
    title = f"{meta.get('rig', '?')} / {meta.get('scenario', '?')} / seed {meta.get('seed', '?')}"
    truth = read_topic(log, "/sim/truth")
    tm = read_topic(log, "/fc/telemetry")
    t0 = truth["log_time_ns"][0] if truth.get("log_time_ns") is not None and truth["log_time_ns"].size else 0
    t = (truth["log_time_ns"] - t0) / 1e9 if truth.get("log_time_ns") is not None else np.zeros(0)
    t_tm = (tm["log_time_ns"] - t0) / 1e9 if tm.get("log_time_ns") is not None and tm["log_time_ns"].size else None
    figs: list[tuple[str, object]] = []

    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 8))
    for ax, axis in zip(axes, ("roll", "pitch", "yaw"), strict=True):
        v = _get(truth, f"euler_deg.{axis}")
        if v is not None:
            ax.plot(t, v, label=f"{axis} truth")
        ref = _get(tm, f"{axis}_ref_deg", f"ref_{axis}_deg")
        if ref is not None and t_tm is not None:
            ax.plot(t_tm, ref, "--", label=f"{axis} reference (telemetry)")
        ax.set_ylabel("deg")
        _legend_outside(ax)
        ax.grid(True)
    axes[0].set_title(f"attitude - {title}")
    axes[-1].set_xlabel("sim time [s]")
    figs.append(("attitude", fig))

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
    _legend_outside(ax)
    figs.append(("altitude", fig))

    cmd = read_topic(log, "/hil/esc/command")
    out = read_topic(log, "/hil/esc/output")
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
    targets = _get(cmd, "targets_us")
    if targets is not None:
        tc = (cmd["log_time_ns"] - t0) / 1e9
        for i in range(targets.shape[1]):
            color, style = MOTOR_STYLES[i % len(MOTOR_STYLES)]
            axes[0].plot(tc, targets[:, i], lw=1.0, color=color, ls=style, label=f"motor {i}")
    axes[0].set_ylabel("ESC command [us]")
    _legend_outside(axes[0])
    thr = _get(out, "throttle")
    if thr is not None:
        to = (out["log_time_ns"] - t0) / 1e9
        for i in range(thr.shape[1]):
            color, style = MOTOR_STYLES[i % len(MOTOR_STYLES)]
            axes[1].plot(to, thr[:, i], lw=1.0, color=color, ls=style, label=f"motor {i}")
    axes[1].set_ylabel("throttle seen by the ESC")
    _legend_outside(axes[1])
    axes[1].set_xlabel("sim time [s]")
    axes[0].set_title(f"motors - {title}")
    for ax in axes:
        ax.grid(True)
    figs.append(("motors", fig))
    return figs


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()  # type: ignore[attr-defined]
    # "tight" keeps the legends placed outside the axes inside the image
    fig.savefig(path, dpi=110, bbox_inches="tight")  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path
