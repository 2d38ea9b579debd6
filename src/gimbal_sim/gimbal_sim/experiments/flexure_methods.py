"""Paper 5's two attitude-matching methods on the same runs: accuracy and CPU time per LGU
pair of the original (eq. 1, 27 states) and the simplified (eq. 5, 18 states) filter, one
table (``gimbal-bench flexure``; ``--turn`` on the turning manoeuvre of ``ship_flexure_turn``).

Each seed is one ship simulation whose every LGU pair goes to both filters, in alternating
order (:func:`.flexure.run_flexure_comparison`), so the two methods see the same samples and
the same machine load. The time per pair is this process's CPU time around the filter calls
(``time.process_time``): a busy machine still slows both (shared caches and cores), so the
table gives the load average with it.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingParams
from gimbal_estimators.flexure_estimator_params import METHODS
from gimbal_estimators.flexure_kf import QS_MODELS, FlexureKfParams

from ..world.sensors import FlexureParams
from .flexure import TURN_FLEXURE, TURN_PROFILE, model_params, run_flexure_comparison

#: the flexure filter's cost per LGU pair [µs]: 1 % of the 100 ms between 10 Hz pairs
FLEXURE_TARGET_US = 1000.0

__all__ = ["FLEXURE_TARGET_US", "QS_MODELS", "MethodRow", "method_table", "run_method_study"]


@dataclass(frozen=True)
class MethodRow:
    """One filter (quasi-static ``model`` by ``method``) over the seeds: per-seed total-flexure
    RMS error ``rms_arcsec`` (seeds, 3), mean NEES (3 dof) ``nees`` (seeds,), fraction of the
    quasi-static flexure's 200 s helm/turn tone left in the error ``helm_left`` (seeds, 3),
    final bias-difference error ``bias_diff_final_deg_h`` (seeds, 3), and the mean time per
    LGU pair ``us_per_pair`` [µs]."""

    model: str
    method: str
    rms_arcsec: np.ndarray
    nees: np.ndarray
    helm_left: np.ndarray
    bias_diff_final_deg_h: np.ndarray
    us_per_pair: float


def run_method_study(duration_s: float, seeds: list[int], models: tuple[str, ...] = ("random_walk_rate",),
                     turn: bool = False, convergence_s: float = 600.0) -> list[MethodRow]:
    """Both methods for each quasi-static model of ``models`` on each seed's run (10 Hz LGUs,
    the ``ship_flexure`` truth; ``turn``: ``ship_flexure_turn``'s). Rows in model, method order."""
    labels = model_params(models, FlexureKfParams(), methods=METHODS)
    per_seed: list[dict[str, Any]] = []
    for seed in seeds:
        per_seed.append(run_flexure_comparison(
            duration_s, seed, models=labels, sim_rate_hz=10.0, lgu_rate_hz=10.0, convergence_s=convergence_s,
            flexure=FlexureParams(**TURN_FLEXURE) if turn else None,
            **({"profile": "sinusoids", "profile_params": TURN_PROFILE} if turn else {})))
    rows = []
    for label, params in labels.items():
        runs = [r[label] for r in per_seed]
        metric = lambda key: np.array([np.asarray(r.metrics[key], float) for r in runs])  # noqa: E731
        rows.append(MethodRow(
            model=params.quasi_static_model,
            method="original" if isinstance(params, AttitudeMatchingParams) else "simplified",
            rms_arcsec=metric("total_rms_arcsec"), nees=metric("total_nees_mean"),
            helm_left=metric("helm_error_fraction"),
            bias_diff_final_deg_h=metric("bias_diff_err_final_deg_h"),
            us_per_pair=float(np.mean([r.filter_us_per_pair for r in runs]))))
    return rows


def method_table(rows: list[MethodRow], turn: bool) -> str:
    """The rows as one Markdown table, then the CPU ratio original/simplified per model and the
    load average the times were taken under."""
    f = lambda v, d=1: ", ".join(f"{x:.{d}f}" for x in v)  # noqa: E731
    tone = "turn flexure left in the error" if turn else "helm flexure left in the error"
    lines = [f"| quasi-static model | method | total flexure RMS error, mean of seeds (roll, pitch, yaw) [″] "
             f"| worst seed [″] | mean NEES (3 dof) | {tone} (200 s tone) "
             f"| bias diff error at the end, worst abs [°/h] | CPU per LGU pair [µs] |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        verdict = "" if r.us_per_pair < FLEXURE_TARGET_US else f" (over the {FLEXURE_TARGET_US:g} µs target)"
        lines.append(f"| {r.model} | {r.method} | {f(r.rms_arcsec.mean(0))} | {f(r.rms_arcsec.max(0))} "
                     f"| {r.nees.mean():.2f} | {f(r.helm_left.mean(0), 2)} "
                     f"| {f(np.abs(r.bias_diff_final_deg_h).max(0), 4)} | {r.us_per_pair:.1f}{verdict} |")
    for model in dict.fromkeys(r.model for r in rows):
        cost = {r.method: r.us_per_pair for r in rows if r.model == model}
        lines.append(f"{model}: CPU original / simplified = {cost['original'] / cost['simplified']:.2f}")
    lines.append("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    return "\n".join(lines)
