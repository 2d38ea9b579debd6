"""Plots of paper 4's error study (:mod:`gimbal_sim.experiments.free_gyro_errors`): Monte Carlo
std against the linear model's σ per variant and output, and every fix's north/east error
against the FDOP·σ_θ circle of eq. 38."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..figures import pyplot, save


def ratio_plot(path: Path, tables: dict[str, dict[str, Any]], outputs: Sequence[str]) -> None:
    """Monte Carlo std / model σ (``tables``: variant -> its ``variant_table``) per output,
    one marker series per variant, with the ±15 % band of the acceptance."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9.0, 4.0), constrained_layout=True)
    x = np.arange(len(outputs) + 1)
    for i, (variant, t) in enumerate(tables.items()):
        r = [t[name]["ratio"] for name in outputs] + [t["position_drms_m"]["ratio"]]
        ax.plot(x + 0.08 * (i - len(tables) / 2), r, "o", label=f"{variant} ({t['n_fixes']} runs)")
    ax.axhspan(0.85, 1.15, color="0.9", zorder=0, label="±15 %")
    ax.axhline(1.0, color="k", linewidth=0.8)
    ax.set_xticks(x, [*outputs, "position drms"], fontsize=8)
    ax.set_ylabel("Monte Carlo std / model σ")
    ax.set_title("paper 4 linear error model against Monte Carlo (last fix of each run)", fontsize=9)
    ax.legend(fontsize=7, ncol=3)
    save(fig, path)


def circle_plot(path: Path, runs: Sequence[dict], variant: str) -> None:
    """Every fix's north/east error scaled by its FDOP·σ_θ radius (eq. 38), against the unit
    circle, with the fraction inside and the probability the covariance implies."""
    plt = pyplot()
    fixes = [f for r in runs for f in r["fixes"]]
    e = np.array([np.array(f["errors"][2:4]) / f["fdop_radius_m"] for f in fixes])
    inside = float(np.mean(np.hypot(e[:, 0], e[:, 1]) <= 1.0))
    implied = float(np.mean([f["p_circle"] for f in fixes]))
    fig, ax = plt.subplots(figsize=(5.0, 5.0), constrained_layout=True)
    ax.plot(e[:, 1], e[:, 0], ".", markersize=2, alpha=0.6)
    a = np.linspace(0.0, 2.0 * math.pi, 200)
    ax.plot(np.sin(a), np.cos(a), "r", label="FDOP·σ_θ")
    ax.set_aspect("equal")
    ax.set_xlabel("east error / FDOP·σ_θ")
    ax.set_ylabel("north error / FDOP·σ_θ")
    ax.set_title(f"{variant}: {inside:.3f} of {len(e)} fixes inside\n(covariance implies {implied:.3f}, "
                 f"paper 1 − e⁻¹ = {1 - math.exp(-1):.3f})", fontsize=9)
    ax.legend(fontsize=8)
    save(fig, path)
