"""The ``slew`` report: how a stabilised sight follows an operator's step command, from the bag.

The run (scenario ``sighting_slew``) holds the LOS, then the ``operator`` node's scripted
stick (``script: step``) commands ``step_rate_deg_s`` (q in elevation, r in azimuth) from
``step_start_s`` for ``step_duration_s`` through the controller's operator input. From the
truth the bag recorded (``/truth/gimbal/imu``: the inner gimbal's inertial rate ω_im^m at every
step; ``/truth/gimbal/gyro_bias``: the gyro's true bias (0, q, r)):

* steady state: the mean true inertial LOS rate (q, r) over the last half of the slew against
  the command, in % of it (the acceptance: within 2 %); and against the command minus the
  true gyro bias, which is what a loop closed on a biased gyro must follow;
* settling time per axis (the usual 2 % one): from the command's stamp to the last time the
  true rate, averaged over :data:`SMOOTH_S` (the vehicle's vibration is not the loop's error)
  and placed at its window's centre, lies outside ±2 % of the command around its steady-state
  value;
* the ``sighting`` report's figures (:mod:`.sighting`), whose ``bias_nees_mean_after_30s`` is
  the EKF's NEES while slewing when the command starts at 30 s and the run ends with it;
* ``slew_nees``: the EKF's (b_q, b_r) NEES at each of its outputs while the command is on
  (``t_s`` from the command's start; σ per axis from ``~/bias_sigma``), which a campaign
  averages over seeds step by step (``experiments.slew.nees_per_step``).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..bag.reader import BagError
from ..nodes.operator_params import PARAMS as OPERATOR_PARAMS
from .common import load_series, plot, times, vectors
from .sighting import TRUTH_BIAS, TRUTH_LOS, _figures, analyse
from .generic import generic_report

#: tolerance of the acceptance, a fraction of the command
BAND = 0.02
#: moving average of the true rate for the settling time [s]
SMOOTH_S = 0.1


def step_command(bag_dir: Path) -> tuple[float, float, tuple[float, float], float]:
    """(start [s], duration [s], (q, r) [rad/s], the run's step rate [Hz]) of the run's
    scripted step, from its scenario.yaml (the node's defaults for what it leaves out)."""
    data = yaml.safe_load((Path(bag_dir) / "scenario.yaml").read_text()) if (Path(bag_dir) / "scenario.yaml").is_file() \
        else {}
    nodes = (data or {}).get("nodes", {})
    given = next((n.get("params", {}) for name, n in nodes.items()
                  if n.get("executable", name) == "operator"), None)
    if given is None or given.get("script") != "step":
        raise BagError(f"{bag_dir}: the slew report needs an operator node with script: step in its scenario.yaml")
    v = {p.name: p.default for p in OPERATOR_PARAMS} | given
    q, r = (math.radians(float(x)) for x in v["step_rate_deg_s"])
    return float(v["step_start_s"]), float(v["step_duration_s"]), (q, r), float(data.get("sim_rate_hz", 1000.0))


def _settling_time(t: np.ndarray, rate: np.ndarray, final: float, command: float, window: int) -> float:
    smooth = np.convolve(rate, np.ones(window) / window, mode="valid")
    ts = t[(window - 1) // 2:len(t) - window // 2]  # each average at its window's centre
    outside = np.nonzero(np.abs(smooth - final) > BAND * abs(command))[0]
    return float(ts[outside[-1]] - t[0]) if len(outside) else 0.0


def slew_figures(t: np.ndarray, w_qr: np.ndarray, b_qr: np.ndarray, cmd: tuple[float, float],
                 window: int) -> dict[str, float]:
    """The steady-state and settling figures (module docstring) from the steps since the
    command's start: times ``t`` (N,) [s] from it, the true rate (N, 2) and the true gyro bias
    (N, 2) (q, r) [rad/s], the command (q, r) [rad/s], the smoothing window [steps]."""
    late = t >= 0.5 * t[-1]
    out: dict[str, float] = {}
    for i, axis in ((1, "az"), (0, "el")):
        mean = float(np.mean(w_qr[late, i]))
        out[f"{axis}_rate_deg_s"] = math.degrees(mean)
        out[f"{axis}_error_pct"] = 100.0 * (mean - cmd[i]) / cmd[i]
        offset = float(np.mean(w_qr[late, i] - (cmd[i] - b_qr[late, i])))
        out[f"{axis}_error_vs_cmd_minus_bias_pct"] = 100.0 * offset / cmd[i]
        out[f"{axis}_settling_time_s"] = _settling_time(t, w_qr[:, i], mean, cmd[i], window)
    return out


def slew_analysis(bag_dir: Path) -> dict[str, Any]:
    """The run's figures: ``slew`` (:func:`slew_figures`), ``sighting`` and ``slew_nees``
    (module docstring), with the series plotted (``t``, ``rate_qr``, ``command``); ``slew``
    None (and a ``note``) when the run ends before the command."""
    start, duration, cmd, rate = step_command(bag_dir)
    series, _ = load_series(bag_dir, {TRUTH_LOS, TRUTH_BIAS})
    truth, bias = series.get(TRUTH_LOS), series.get(TRUTH_BIAS)
    if not truth or not bias:
        raise BagError(f"{bag_dir}: the slew report needs {TRUTH_LOS} and {TRUTH_BIAS}")
    t_truth = times(truth)
    t0 = t_truth[0]
    w = {round(t * 1e9): (m.angular_velocity.y, m.angular_velocity.z) for t, m in truth}
    b = {round(t * 1e9): (y, z) for t, (_, y, z) in zip(times(bias), vectors(bias))}
    stamps = [s for s in sorted(w) if s in b and (s - round(t0 * 1e9)) * 1e-9 >= start - 0.5 / rate]
    a = analyse(bag_dir)
    if len(stamps) < 2:  # the run ended before the command: its sighting figures only
        return {"slew": None, "sighting": _figures(a), "note": f"the run ends before its step command ({start:g} s)"}
    t = np.array([(s - stamps[0]) * 1e-9 for s in stamps])
    slew = slew_figures(t, np.array([w[s] for s in stamps]), np.array([b[s] for s in stamps]), cmd,
                        max(1, int(round(SMOOTH_S * rate))))
    out: dict[str, Any] = {"slew": slew, "sighting": _figures(a), "t": t, "command": cmd,
                           "rate_qr": np.array([w[s] for s in stamps])}
    if "nees_bias" in a:
        during = (a["t_ekf"] >= start) & (a["t_ekf"] < start + duration - 0.5 / rate)
        out["slew_nees"] = {"t_s": [round(float(v), 9) for v in a["t_ekf"][during] - start],
                            "bias_nees": [float(v) for v in a["nees_bias"][during]]}
    return out


def slew_report(bag_dir: Path, out: Path) -> dict:
    """One run: the slew figures, the sighting figures, the NEES while slewing, and a plot of
    the true LOS rate against the command (``los_rate.png``)."""
    metrics = generic_report(bag_dir, out)
    a = slew_analysis(bag_dir)
    metrics.update(slew=a["slew"], sighting=a["sighting"])
    if a["slew"] is None:
        metrics["slew_note"] = a["note"]
        return metrics
    if "slew_nees" in a:
        metrics["slew_nees"] = a["slew_nees"]
    deg = np.degrees(a["rate_qr"])
    plot(out / "los_rate.png", "True inertial LOS rate from the command's start", a["t"],
         {"elevation q [deg/s]": deg[:, 0], "azimuth r [deg/s]": deg[:, 1],
          "command q": np.full(len(deg), math.degrees(a["command"][0])),
          "command r": np.full(len(deg), math.degrees(a["command"][1]))}, "LOS rate [deg/s]")
    metrics["plots"].append("los_rate.png")
    return metrics


def slew_comparison(runs: dict[str, Path], out: Path) -> dict:
    """Variants side by side: each case's slew figures in one table."""
    analysed = {name: slew_analysis(bag) for name, bag in runs.items()}
    cases = {name: a["slew"] for name, a in analysed.items()}
    if any(c is None for c in cases.values()):
        note = next(a["note"] for a in analysed.values() if a["slew"] is None)
        return {"cases": cases, "table": f"Step command: none ({note})", "plots": [],
                "runs": {k: str(v) for k, v in runs.items()}}
    keys = list(next(iter(cases.values())))
    rows = [("figure", *cases)] + [(key, *(f"{c[key]:+.4f}" for c in cases.values())) for key in keys]
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]))]
    table = "\n".join("  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(r, widths)))
                      for r in rows)
    return {"cases": cases, "table": "Step command followed by the LOS (truth):\n" + table, "plots": [],
            "runs": {k: str(v) for k, v in runs.items()}}
