"""Slew acceptance: paper 1's vehicle and sensors (scenario
``sighting_land_vehicle``), the LOS held for ``hold_s`` (the EKF converges), then an
operator's step command of ``az_rate_deg_s`` in azimuth (r) and ``el_rate_deg_s`` in
elevation (q) for ``slew_s``, sent at ``command_rate_hz`` (a joystick's autorepeat) on the
controller's operator input (:class:`gimbal_control.operator_command.OperatorCommand`).

Per run (no ROS: the scenario's cores, :func:`gimbal_sim.core.core_loop.core_plan`, with
the commander's stage before the controller's), from the truth:

* steady state: the mean true inertial LOS rate (q, r) over the last half of the slew
  against the command, in % of it (the acceptance: within 2 %); and against the command
  minus the true gyro bias, which is what a loop closed on a biased gyro must follow;
* settling time per axis (the usual 2 % one): from the command's stamp to the last time the
  true rate, averaged over ``SMOOTH_S`` (the vehicle's vibration is not the loop's error),
  lies outside ±2 % of the command around its steady-state value (the bias offsets that
  value; it is the first figure's);
* the sighting figures of the run (:func:`..reports.sighting.sighting_figures`), whose
  ``bias_nees_mean_after_30s`` is the EKF's NEES while slewing when ``hold_s`` = 30 and the
  run ends with the slew (the campaign report tests it against its 95 % band over seeds);
* the EKF's (b_q, b_r) NEES at each of its outputs while the command is on (``series``: ``t_s`` from
  the command's start, ``bias_nees``; the sighting report's per-output NEES, σ per axis).

Over N seeds (:func:`nees_per_step`), the per-step NEES averaged over the seeds at each
output, against the 95 % band of an N-run average of a 2-dof NEES, χ²(2N)/N: the fraction
of the slew's steps inside it ("the NEES stays inside its 95 % band"; a consistent filter
has about 95 % of its steps inside, the steps being correlated in time), and the fractions
above (optimistic) and below (pessimistic).

``python -m gimbal_sim.experiments.slew --seeds 20 --out DIR`` runs the campaign (the
campaign engine: ``--jobs``, ``--resume``; its report in ``DIR/report``) and prints per
variant each figure's mean and 95 % interval over the seeds, the N-run time-averaged NEES
against its band, and the per-step one's fraction inside it.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gimbal_kinematics.stamps import step_stamp_ns

from ..campaign.experiment import ExperimentCampaign, run_metrics
from ..campaign.report import nees_verdict, stats
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..campaign.spec import CampaignSpec
from ..core.core_loop import core_plan, run_stages
from ..graph.scenario import load, variant as scenario_variant
from ..reports.core_metrics import SightingCollector
from ..reports.sighting import analyse_series

MODES = ("ekf_off", "ekf_on")
DEFAULTS = {"hold_s": 30.0, "slew_s": 10.0, "az_rate_deg_s": 5.0, "el_rate_deg_s": 2.0, "command_rate_hz": 20.0}
#: tolerance of the acceptance, a fraction of the command
BAND = 0.02
#: moving average of the true rate for the settling time [s]
SMOOTH_S = 0.1


class _SlewObserver(SightingCollector):
    """The sighting series plus the true LOS rate and gyro bias of every step of the slew."""

    def __init__(self, scenario, start_ns: int) -> None:
        super().__init__(scenario)
        self.start_ns = start_ns
        self.ts: list[int] = []
        self.rate_qr: list[tuple[float, float]] = []
        self.bias_qr: list[tuple[float, float]] = []

    def __call__(self, bus: Any) -> None:
        super().__call__(bus)
        t = step_stamp_ns(bus.k, self.rate)
        if t >= self.start_ns and bus.gyro is not None:
            w = bus.truth.omega_im_m
            self.ts.append(t)
            self.rate_qr.append((w[1], w[2]))
            self.bias_qr.append(tuple(bus.gyro.true_bias))


def _settling_time(t: np.ndarray, rate: np.ndarray, final: float, command: float, window: int) -> float:
    smooth = np.convolve(rate, np.ones(window) / window, mode="valid")
    ts = t[(window - 1) // 2:len(t) - window // 2]  # each average at its window's centre
    outside = np.nonzero(np.abs(smooth - final) > BAND * abs(command))[0]
    return float(ts[outside[-1]] - t[0]) if len(outside) else 0.0


def run_slew(mode: str, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """One run (module docstring); returns its metrics."""
    o = {**DEFAULTS, **options}
    base = scenario_variant(load("sighting_land_vehicle"), mode)
    scenario = dataclasses.replace(base, seed=seed, duration_s=o["hold_s"] + o["slew_s"])
    vehicle, controlled, stages = core_plan(scenario)
    rate = scenario.sim_rate_hz
    every = int(round(rate / o["command_rate_hz"]))
    start_k, end_k = int(round(o["hold_s"] * rate)), int(round((o["hold_s"] + o["slew_s"]) * rate))
    cmd = (math.radians(o["el_rate_deg_s"]), math.radians(o["az_rate_deg_s"]))

    def commander(bus) -> None:
        on = start_k <= bus.k < end_k and (bus.k - start_k) % every == 0
        bus.operator = (step_stamp_ns(bus.k, rate), *cmd) if on else None

    stages.insert(len(stages) - 1, commander)  # before the controller, as its input
    start_ns = step_stamp_ns(start_k, rate)
    observer = _SlewObserver(scenario, start_ns)
    run_stages(vehicle, stages, controlled=controlled, observer=observer)
    t = (np.array(observer.ts) - start_ns) * 1e-9
    w = np.array(observer.rate_qr)
    b = np.array(observer.bias_qr)
    late = t >= 0.5 * t[-1]
    window = max(1, int(round(SMOOTH_S * rate)))
    slew: dict[str, Any] = {}
    for i, axis in ((1, "az"), (0, "el")):
        mean = float(np.mean(w[late, i]))
        slew[f"{axis}_rate_deg_s"] = math.degrees(mean)
        slew[f"{axis}_error_pct"] = 100.0 * (mean - cmd[i]) / cmd[i]
        offset = float(np.mean(w[late, i] - (cmd[i] - b[late, i])))
        slew[f"{axis}_error_vs_cmd_minus_bias_pct"] = 100.0 * offset / cmd[i]
        slew[f"{axis}_settling_time_s"] = _settling_time(t, w[:, i], mean, cmd[i], window)
    metrics = {"slew": slew, **observer.metrics(Path("/nonexistent"))}
    a = analyse_series(observer.series(), 0.0, True)  # the NEES depends on neither the site nor the earth rate
    if "nees_bias" in a:
        during = (a["t_ekf"] >= o["hold_s"]) & (a["t_ekf"] < o["hold_s"] + o["slew_s"] - 0.5 / rate)
        metrics["series"] = {"t_s": [round(float(v), 9) for v in a["t_ekf"][during] - o["hold_s"]],
                             "bias_nees": [float(v) for v in a["nees_bias"][during]]}
    return metrics


def nees_per_step(series: list[dict[str, list[float]]], dof: int = 2) -> dict[str, Any]:
    """The runs' per-step NEES (each a ``series`` of :func:`run_slew`, on one time grid)
    averaged over the runs at each step, against χ²(N·dof)/N's 95 % band (module docstring);
    ValueError if the runs' grids differ."""
    from scipy.stats import chi2

    t = series[0]["t_s"]
    if any(s["t_s"] != t for s in series):
        raise ValueError("the runs' NEES are not on one time grid (different options?)")
    n = len(series)
    avg = np.mean(np.array([s["bias_nees"] for s in series], float), axis=0)
    lo, hi = (float(b) for b in chi2.ppf([0.025, 0.975], n * dof) / n)
    return {"n": n, "steps": int(avg.size), "band95": [lo, hi], "mean": float(np.mean(avg)),
            "inside": float(np.mean((avg >= lo) & (avg <= hi))), "above": float(np.mean(avg > hi)),
            "below": float(np.mean(avg < lo)), "nees": avg, "t_s": np.array(t)}


#: ``engine: core`` only (the commander is a stage, not a node)
CAMPAIGN = ExperimentCampaign(name="slew", variants=MODES, defaults=dict(DEFAULTS), run=run_slew)


def summarize(runs: dict[str, list[tuple[int, dict]]]) -> str:
    """Per variant: each slew figure's mean and 95 % interval over the runs, the per-step NEES
    while slewing averaged over the runs (:func:`nees_per_step`), and the runs' time-averaged
    NEES after 30 s against the 95 % band of its N-run average."""
    lines = []
    for mode, rs in runs.items():
        lines.append(f"{mode} ({len(rs)} runs):")
        for key in rs[0][1]["slew"]:
            st = stats([m["slew"][key] for _, m in rs])
            lines.append(f"  {key:36s} {st['mean']:+.4f}  95 % CI [{st['ci95'][0]:+.4f}, {st['ci95'][1]:+.4f}]"
                         f"  range [{st['min']:+.4f}, {st['max']:+.4f}]")
        if all("series" in m for _, m in rs):
            p = nees_per_step([m["series"] for _, m in rs])
            lines.append(f"  bias NEES per step while slewing, mean over the runs at each of {p['steps']} EKF steps: "
                         f"{100 * p['inside']:.1f} % of the steps inside its 95 % band [{p['band95'][0]:.3f}, "
                         f"{p['band95'][1]:.3f}] ({100 * p['above']:.1f} % above, {100 * p['below']:.1f} % below); "
                         f"time mean {p['mean']:.3f}")
        v = nees_verdict([m["sighting"]["bias_nees_mean_after_30s"] for _, m in rs], 2)
        if "mean" not in v:  # nothing after 30 s
            lines.append("  bias NEES after 30 s: none (the run ends before)")
            continue
        lines.append(f"  bias NEES after 30 s (2 dof)           {v['mean']:.3f}  95 % band "
                     f"[{v['band95'][0]:.3f}, {v['band95'][1]:.3f}]: {v['verdict']}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.slew",
                                 description="Slew acceptance on paper 1's vehicle, no ROS: a step "
                                             "command followed by the LOS rate loop, and the EKF's NEES while "
                                             "slewing, over seeds (a campaign).")
    ap.add_argument("--seeds", type=int, default=1, metavar="N", help="runs per variant (seeds 1..N)")
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    for key, value in DEFAULTS.items():
        ap.add_argument("--" + key.replace("_", "-"), type=float, default=value, help=f"default {value}")
    add_engine_arguments(ap, graph=False)
    a = ap.parse_args(argv)
    options = {key: getattr(a, key) for key in DEFAULTS}
    if a.seeds < 1 or not all(0.0 < v < math.inf for v in options.values()):
        ap.error("--seeds must be >= 1 and every option a finite number > 0")
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(range(1, a.seeds + 1)),
                        variants=tuple(a.modes), engine="core", options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        print(summarize(run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
