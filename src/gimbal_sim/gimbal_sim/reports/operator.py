"""The simulated operator's figures (scenario ``sighting_operator``): how often a
person at the sight must re-centre the target with the gyro-bias EKF off and on (paper 1,
§1 and §6: without the filter "the biases should be corrected periodically by the user").

From the bag alone (``/operator/los_rate``, ``/operator/pointing_error``), not from the
model's own bookkeeping (:meth:`..world.operator_model.OperatorModel.statistics`, which a
test compares with these):

* corrections: runs of non-zero commands (each starts when the operator moves the stick);
  corrections per minute over the observed time (from the target's capture to the end);
* the fraction of the observed time on target: ε at or inside ``tolerance_mrad`` at the
  start of each sample interval, weighted by the interval;
* the mean time between the starts of successive corrections (NaN with fewer than two).
  A mean over runs of this figure is censored: it leaves out the calm runs (none or one
  correction), so it is biased low;
* the observed time per correction, ``observed_s / corrections`` (inf with none): the
  uncensored figure. Over runs, pool it as Σ observed_s / Σ corrections (the mean of the
  per-run ratios, or of the finite ones, is not that); with the same observed time in every
  run it is 60 / (the runs' mean corrections per minute);
* the RMS and peak of the true pointing error ε.

The sighting figures of the run (drift, bias NEES) come with them
(:func:`.sighting.sighting_report`); the comparison tabulates the variants and the ratio of
their correction rates.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from ..world.operator_model import OperatorModelParams
from .common import load_series, times, vectors
from .sighting import sighting_report

COMMAND = "/operator/los_rate"
ERROR = "/operator/pointing_error"


def operator_tolerance(bag_dir: Path) -> float:
    """The operator's ``tolerance_mrad`` of the run [rad], from its scenario.yaml (default if absent)."""
    scenario_file = Path(bag_dir) / "scenario.yaml"
    params = {}
    if scenario_file.is_file():
        nodes = yaml.safe_load(scenario_file.read_text()).get("nodes", {})
        params = next((n.get("params", {}) for n in nodes.values() if n.get("executable") == "operator"), {})
    return float(params.get("tolerance_mrad", OperatorModelParams().tolerance_mrad)) * 1e-3


def operator_figures(t: np.ndarray, error: np.ndarray, command: np.ndarray, tolerance: float) -> dict:
    """The figures (module docstring) from the operator's samples: times ``t`` (N,) [s], its
    pointing error (N, 3) (ε, e_q, e_r) [rad] (ε NaN before the capture) and commands (N, 3)
    (0, q, r) [rad/s] of the same steps, at ``tolerance`` [rad]."""
    t = np.asarray(t, dtype=float)
    eps = np.asarray(error, dtype=float).reshape(-1, 3)[:, 0]
    cmd = np.asarray(command, dtype=float).reshape(-1, 3)
    seen = np.isfinite(eps)
    t, eps, cmd = t[seen], eps[seen], cmd[seen]
    nan = float("nan")
    if len(t) < 2:
        return {"corrections": 0, "corrections_per_min": nan, "time_on_target_fraction": nan,
                "mean_time_between_corrections_s": nan, "observed_s": 0.0, "observed_time_per_correction_s": nan,
                "pointing_error_rms_mrad": nan, "pointing_error_peak_mrad": nan}
    dt = np.diff(t)
    observed = float(t[-1] - t[0])
    moving = (cmd[:, 1] != 0.0) | (cmd[:, 2] != 0.0)
    onsets = t[moving & ~np.concatenate(([False], moving[:-1]))]
    gaps = np.diff(onsets)
    return {
        "corrections": int(len(onsets)),
        "corrections_per_min": 60.0 * len(onsets) / observed,
        "time_on_target_fraction": float(np.sum(dt[eps[:-1] <= tolerance]) / observed),
        "mean_time_between_corrections_s": float(np.mean(gaps)) if len(gaps) else nan,
        "observed_s": observed,
        "observed_time_per_correction_s": observed / len(onsets) if len(onsets) else math.inf,
        "pointing_error_rms_mrad": float(np.sqrt(np.mean(eps * eps))) * 1e3,
        "pointing_error_peak_mrad": float(np.max(eps)) * 1e3,
    }


def analyse(bag_dir: Path) -> dict:
    series, _ = load_series(bag_dir, {COMMAND, ERROR})
    cmd, err = series.get(COMMAND, []), series.get(ERROR, [])
    if len(cmd) != len(err):
        raise ValueError(f"{bag_dir}: {len(cmd)} operator commands but {len(err)} pointing errors")
    return operator_figures(times(err), vectors(err), vectors(cmd), operator_tolerance(bag_dir))


def sighting_operator_report(bag_dir: Path, out: Path) -> dict:
    """One run: the sighting figures and the operator's (module docstring)."""
    metrics = sighting_report(bag_dir, out)
    metrics["operator"] = analyse(bag_dir)
    return metrics


def _fmt(value: float, spec: str) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value, spec)


def sighting_operator_comparison(runs: dict[str, Path], out: Path) -> dict:
    """Variants side by side: corrections per minute, time on target, mean time between
    corrections, observed time per correction, pointing error; the ratio of the first
    variant's correction rate to each."""
    cases = {name: analyse(bag) for name, bag in runs.items()}
    first = next(iter(cases.values()))["corrections_per_min"]
    rows = [("case", "corrections/min", "on target", "mean between [s]", "observed/correction [s]",
             "eps RMS/peak [mrad]", "ratio")]
    for name, c in cases.items():
        ratio = first / c["corrections_per_min"] if c["corrections_per_min"] else math.inf
        c["correction_ratio_to_first"] = ratio
        rows.append((name, _fmt(c["corrections_per_min"], ".2f"), _fmt(c["time_on_target_fraction"], ".3f"),
                     _fmt(c["mean_time_between_corrections_s"], ".1f"),
                     _fmt(c["observed_time_per_correction_s"], ".1f"),
                     f"{_fmt(c['pointing_error_rms_mrad'], '.2f')} / {_fmt(c['pointing_error_peak_mrad'], '.2f')}",
                     _fmt(ratio, ".1f")))
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]))]
    table = "\n".join("  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in
                                enumerate(zip(r, widths))) for r in rows)
    return {"cases": cases, "table": "Simulated operator's corrections:\n" + table, "plots": [],
            "runs": {k: str(v) for k, v in runs.items()}}
