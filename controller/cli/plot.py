"""``imotion plot FILE.mcap``: PNG plots of a recording or a black-box file (matplotlib).

Writes next to the file (or into ``--out``):

- ``<name>-joints.png``: every joint over time [deg, or mm for prismatic joints], measured
  (and commanded when the file has it), with its position limits as dashed lines when the
  file's ``imotion`` metadata lists them (black-box files do);
- ``<name>-tracking.png``: commanded minus measured per joint, and the largest one (files
  with commanded joints, i.e. black-box files);
- ``<name>-timing.png``: the loop's wake latency and compute time [us], per cycle (black box)
  or the p50/p99/max the daemon published (``imotion record``).

Needs the optional ``plot`` extra (``pip install 'imotion[plot]'``: matplotlib, mcap).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from controller.client.recording import Recording, metadata_limits, read_mcap


def _figure(rows: int, cols: int, height: float) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, height * rows), squeeze=False)
    return fig, axes


def _save(fig: Any, path: Path) -> Path:
    from matplotlib import pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _joint_series(rec: Recording, topic: str) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Times [s from the start], joint names, positions (samples x joints) [rad, m]."""
    msgs = rec.messages(topic)
    if not msgs:
        return np.zeros(0), [], np.zeros((0, 0))
    names = [j["name"] for j in msgs[0][1].get("joints", [])]
    t = np.array([m[0] for m in msgs])
    q = np.array(
        [[j.get("position", 0.0) for j in m[1].get("joints", [])] for m in msgs], dtype=float
    )
    return t, names, q


#: Black-box states in which the drives do not follow the command.
UNFOLLOWED = ("servo off", "alarm")


def _mark_alarm(rec: Recording, axes: Any, t0: float) -> None:
    """A vertical line at the alarm of a black-box file (metadata ``alarm``)."""
    text = rec.metadata.get("alarm", {}).get("time")
    if not text:
        return
    from datetime import datetime

    at = datetime.fromisoformat(text).timestamp() - t0
    for row in axes:
        for ax in row:
            if ax.has_data():
                ax.axvline(at, color="red", lw=1.0, alpha=0.6)


def _scale(kind: str) -> tuple[float, str]:
    return (1e3, "mm") if kind == "prismatic" else (180.0 / math.pi, "deg")


def plot_joints(rec: Recording, path: Path) -> Path | None:
    measured = "/joint_states/measured" if "/joint_states/measured" in rec.topics else None
    topic = measured or "/joint_states"
    t, names, q = _joint_series(rec, topic)
    if not names:
        return None
    t0 = t[0]
    _, _, q_cmd = _joint_series(rec, "/joint_states/commanded")
    limits = metadata_limits(rec)
    cols = 4
    rows = -(-len(names) // cols)
    fig, axes = _figure(rows, cols, 2.1)
    for k, name in enumerate(names):
        ax = axes[k // cols][k % cols]
        info = limits.get(name, {})
        kind = info.get("kind") or ("prismatic" if name.startswith("VEHICLE/") and
                                     name[-1] in "12" else "revolute")  # fmt: skip
        scale, unit = _scale(kind)
        ax.plot(t - t0, q[:, k] * scale, label="measured", lw=1.2)
        if q_cmd.shape == q.shape:
            ax.plot(t - t0, q_cmd[:, k] * scale, label="commanded", lw=0.8, ls="--")
        for bound in ("lower", "upper"):
            if info.get(bound) is not None:
                ax.axhline(info[bound] * scale, color="red", ls=":", lw=1.0)
        ax.set_title(name, fontsize=9)
        ax.set_ylabel(unit, fontsize=8)
        ax.tick_params(labelsize=7)
    for k in range(len(names), rows * cols):
        axes[k // cols][k % cols].axis("off")
    _mark_alarm(rec, axes, t0)
    axes[0][0].legend(fontsize=7)
    fig.suptitle("joints vs limits (red: position limits); time [s]")
    return _save(fig, path)


def plot_tracking(rec: Recording, path: Path) -> Path | None:
    t, names, q = _joint_series(rec, "/joint_states/measured")
    _, _, q_cmd = _joint_series(rec, "/joint_states/commanded")
    if not names or q_cmd.shape != q.shape:
        return None
    limits = metadata_limits(rec)
    scales = np.array([_scale(limits.get(n, {}).get("kind", "revolute"))[0] for n in names])
    err = (q_cmd - q) * scales
    # Servo off or in alarm the drives do not follow the command: no tracking error then.
    states = [c[1].get("state") for c in rec.messages("/blackbox/cycle")]
    if len(states) == len(err):
        err[np.array([s in UNFOLLOWED for s in states])] = np.nan
    fig, axes = _figure(2, 1, 3.0)
    fig.set_size_inches(11, 6)
    t0 = t[0]
    t = t - t0
    worst = np.argsort(-np.nan_to_num(np.abs(err)).max(axis=0))[:8]
    for k in worst:
        axes[0][0].plot(t, err[:, k], label=names[k], lw=1.0)
    axes[0][0].set_ylabel("commanded - measured [deg, mm]")
    axes[0][0].set_title("tracking error per joint (the 8 largest; none while servo off or "
                         "in alarm)")  # fmt: skip
    axes[0][0].legend(fontsize=7, ncol=4)
    largest = np.full(len(t), np.nan)
    rows = ~np.isnan(err).all(axis=1)
    largest[rows] = np.nanmax(np.abs(err[rows]), axis=1)
    axes[1][0].plot(t, largest, color="black", lw=1.0)
    _mark_alarm(rec, axes, t0)
    axes[1][0].set_ylabel("largest |error| [deg, mm]")
    axes[1][0].set_xlabel("time [s]")
    return _save(fig, path)


def plot_timing(rec: Recording, path: Path) -> Path | None:
    fig, axes = _figure(2, 1, 3.0)
    fig.set_size_inches(11, 6)
    cycles = rec.messages("/blackbox/cycle")
    if cycles:
        t = np.array([c[0] for c in cycles])
        t = t - t[0]
        for ax, key, label in (
            (axes[0][0], "wake_us", "wake latency [us]"),
            (axes[1][0], "compute_us", "compute time [us]"),
        ):
            y = np.array([np.nan if c[1].get(key) is None else c[1][key] for c in cycles])
            ax.plot(t, y, lw=0.8)
            ax.set_ylabel(label)
        axes[0][0].set_title("loop timing, every cycle (red: the alarm)")
        _mark_alarm(rec, axes, float(cycles[0][0]))
    else:
        loop = rec.messages("/loop")
        if not loop:
            from matplotlib import pyplot as plt

            plt.close(fig)
            return None
        t = np.array([m[0] for m in loop])
        t = t - t[0]
        for ax, key, label in (
            (axes[0][0], "wake_us", "wake latency [us]"),
            (axes[1][0], "compute_us", "compute time [us]"),
        ):
            y = np.array([m[1].get(key, [np.nan] * 3) for m in loop], dtype=float)
            for i, stat in enumerate(("p50", "p99", "max")):
                ax.plot(t, y[:, i], label=stat, lw=1.0)
            ax.set_ylabel(label)
            ax.legend(fontsize=7)
        axes[0][0].set_title("loop timing over the last second, as published")
    axes[1][0].set_xlabel("time [s]")
    return _save(fig, path)


def plot_file(path: Path, out_dir: Path | None = None) -> list[Path]:
    """Every plot the file has data for; returns the PNG paths written."""
    rec = read_mcap(Path(path))
    out_dir = Path(out_dir) if out_dir is not None else Path(path).parent
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = Path(path).stem
    written = [
        plot_joints(rec, out_dir / f"{stem}-joints.png"),
        plot_tracking(rec, out_dir / f"{stem}-tracking.png"),
        plot_timing(rec, out_dir / f"{stem}-timing.png"),
    ]
    return [p for p in written if p is not None]
