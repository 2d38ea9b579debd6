"""Slew acceptance, a campaign declaration: scenario ``sighting_slew`` (paper 1's vehicle,
sensors, controller and EKF, variants ``ekf_off`` and ``ekf_on``): the LOS held for
``hold_s`` (the EKF converges), then an operator's step command of ``az_rate_deg_s`` in
azimuth (r) and ``el_rate_deg_s`` in elevation (q) for ``slew_s``, sent at ``command_rate_hz``
(a joystick's autorepeat) by the ``operator`` node's scripted stick (``script: step``) on the
controller's operator input (:class:`gimbal_control.operator_command.OperatorCommand`).

Each run is the scenario's, on the one engine (each with its bag) or in the node graph; its
figures are the ``slew`` report's, from the bag (:mod:`gimbal_sim.reports.slew`: steady state
against the command and against the command minus the true gyro bias, the 2 % settling time,
the sighting figures, and the EKF's (b_q, b_r) NEES at each of its outputs while slewing).

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

import math
from typing import Any, Sequence

import numpy as np

from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, numbered_table, run_metrics
from ..campaign.report import nees_verdict, stats
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..campaign.spec import CampaignSpec
from .engine_runs import run_on_engine

MODES = ("ekf_off", "ekf_on")
DEFAULTS = {"hold_s": 30.0, "slew_s": 10.0, "az_rate_deg_s": 5.0, "el_rate_deg_s": 2.0, "command_rate_hz": 20.0}


def scenario_values(options: dict[str, Any]) -> tuple[float, tuple[tuple[str, Any], ...]]:
    """The options as scenario ``sighting_slew``'s values: the run ends with the slew; the
    operator's step, its rate, and the controller waiting for its commands at that rate."""
    o = {**DEFAULTS, **options}
    return o["hold_s"] + o["slew_s"], (
        ("operator.step_start_s", o["hold_s"]), ("operator.step_duration_s", o["slew_s"]),
        ("operator.step_rate_deg_s", [o["el_rate_deg_s"], o["az_rate_deg_s"]]),
        ("operator.rate_hz", o["command_rate_hz"]), ("los_rate_controller.operator_rate_hz", o["command_rate_hz"]))


def nees_per_step(series: list[dict[str, list[float]]], dof: int = 2) -> dict[str, Any]:
    """The runs' per-step NEES (each a run's ``slew_nees``, :mod:`gimbal_sim.reports.slew`, on one time grid)
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
        if all("slew_nees" in m for _, m in rs):
            p = nees_per_step([m["slew_nees"] for _, m in rs])
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


#: A declaration: scenario ``sighting_slew``'s variants on the one engine (``engine: core``, each
#: run's bag and ``slew`` report) or in the node graph (``engine: graph``).
CAMPAIGN = ExperimentCampaign(name="slew", variants=MODES, defaults=dict(DEFAULTS), run=None,
                              graph=GraphEquivalent("sighting_slew", {m: m for m in MODES}, tuple(DEFAULTS),
                                                    scenario_values),
                              table=numbered_table(summarize))


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.slew",
                                 description="Slew acceptance on paper 1's vehicle (scenario sighting_slew): a "
                                             "step command followed by the LOS rate loop, and the EKF's NEES while "
                                             "slewing, over seeds (a campaign on the one engine or, --engine "
                                             "graph, the real nodes; each run's bag and report kept with --out).")
    ap.add_argument("--seeds", type=int, default=1, metavar="N", help="runs per variant (seeds 1..N)")
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    for key, value in DEFAULTS.items():
        ap.add_argument("--" + key.replace("_", "-"), type=float, default=value, help=f"default {value}")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    options = {key: getattr(a, key) for key in DEFAULTS}
    if a.seeds < 1 or not all(0.0 < v < math.inf for v in options.values()):
        ap.error("--seeds must be >= 1 and every option a finite number > 0")
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(range(1, a.seeds + 1)),
                        variants=tuple(a.modes), engine=a.engine, mode=a.mode, options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        print(summarize(run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN, run_on_engine))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
