"""Plots of paper 2's R/Q study (``experiments.encoder_fusion_study rq --plots DIR``): the
estimated velocity traces of the paper's pairs (like its Figs. 5–7) and the grid of RMS
figures against R and Q."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gimbal_kinematics.maths.units import DEG

from ..figures import pyplot, save


def velocity_traces_plot(path: Path, traces: dict[str, dict[str, np.ndarray]], span_s: tuple[float, float]) -> None:
    """One panel per (R, Q) label of ``traces`` (a run's series: t, feedback_rad_s,
    true_rate_rad_s, gyro_bias_rad_s): the azimuth-axis estimated velocity ω̂ − true rate,
    with the true gyro bias (what raw gyro feedback would leave), over ``span_s`` [s]."""
    plt = pyplot()
    fig, axes = plt.subplots(len(traces), 1, figsize=(7.0, 2.3 * len(traces)), sharex=True, constrained_layout=True)
    for ax, (label, s) in zip(np.atleast_1d(axes), traces.items()):
        t = s["t"]
        keep = (t >= span_s[0]) & (t <= span_s[1])
        err = (s["feedback_rad_s"][keep, 1] - s["true_rate_rad_s"][keep, 1]) / DEG
        # 20 ms means: the gyro's 1 kHz white noise would hide the filter's corrections
        n = 20
        m = len(err) // n * n
        tm = t[keep][:m].reshape(-1, n).mean(axis=1)
        ax.plot(tm, err[:m].reshape(-1, n).mean(axis=1), linewidth=0.9, label="estimated − true velocity (20 ms means)")
        ax.plot(t[keep], s["gyro_bias_rad_s"][keep, 1] / DEG, "k--", linewidth=1.0, label="raw gyro error (bias)")
        ax.axhline(0.0, color="grey", linewidth=0.6)
        ax.set_ylabel("r_m [deg/s]")
        ax.set_title(label, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("t [s]")
    fig.suptitle("Estimated velocity error by filter setting (azimuth axis)", fontsize=10)
    save(fig, path)


def rq_grid_plot(path: Path, table: dict[str, dict[str, Any]], paper_pairs: tuple) -> None:
    """Three heat maps over the (R, Q) grid: stabilization RMS [mrad], slow and fast
    estimated-velocity error [deg/s] (means over the seeds), the paper's pairs circled."""
    plt = pyplot()
    rs = sorted({v["r"] for v in table.values()})
    qs = sorted({v["q"] for v in table.values()})
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 4.0), constrained_layout=True)
    for ax, (key, title) in zip(axes, (("rms_mrad", "stabilization RMS [mrad]"),
                                       ("slow_deg_s", "velocity error, slow [deg/s]"),
                                       ("fast_deg_s", "velocity error, fast [deg/s]"))):
        grid = np.full((len(rs), len(qs)), np.nan)
        for v in table.values():
            grid[rs.index(v["r"]), qs.index(v["q"])] = v[key]["mean"]
        im = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
        for i in range(len(rs)):
            for j in range(len(qs)):
                ax.annotate(f"{grid[i, j]:.3g}", (j, i), ha="center", va="center", fontsize=7, color="w")
        for r, q in paper_pairs:
            if r in rs and q in qs:
                ax.add_patch(plt.Circle((qs.index(q), rs.index(r)), 0.45, fill=False, color="r", linewidth=1.5))
        ax.set_xticks(range(len(qs)), [f"{q:g}" for q in qs])
        ax.set_yticks(range(len(rs)), [f"{r:g}" for r in rs])
        ax.set_xlabel("Q [counts² per step]")
        ax.set_ylabel("R [counts²]")
        ax.set_title(title, fontsize=9)
        fig.colorbar(im, ax=ax)
    fig.suptitle("Paper 2 filter tuning: R against Q (paper's pairs circled)", fontsize=10)
    save(fig, path)
