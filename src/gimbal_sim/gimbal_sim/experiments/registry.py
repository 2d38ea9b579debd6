"""The paper runners' experiment campaigns by name, and how ``gimbal-campaign`` plans and
runs any campaign: a scenario campaign with :func:`gimbal_sim.campaign.spec.plan`, an
experiment campaign with its runner's :class:`~gimbal_sim.campaign.experiment.ExperimentCampaign`.
The one module that imports every runner."""
from __future__ import annotations

import dataclasses
import difflib
import tempfile
from functools import partial
from pathlib import Path
from typing import Any

from ..campaign import engine, spec as scenario_campaign
from ..campaign.engine import Runners
from ..campaign.report import write_campaign_report
from ..campaign.results import CampaignResult, flatten_metrics
from ..campaign.experiment import ExperimentCampaign, experiment_table, plan_experiment
from ..campaign.runner_cli import experiment_runners
from ..campaign.spec import CampaignError, CampaignPlan, CampaignSpec, RunFunction
from ..reports.paper import campaign_paper_figure
from .engine_runs import run_on_engine
from . import encoder_fusion_study, flexure, flexure_sea, free_gyro, free_gyro_errors, navigation, platform_servo, sighting_loop, slew

#: experiment name -> its campaign
EXPERIMENTS: dict[str, ExperimentCampaign] = {
    e.name: e for e in (sighting_loop.CAMPAIGN, flexure.CAMPAIGN, flexure_sea.CAMPAIGN, free_gyro.CAMPAIGN, platform_servo.CAMPAIGN,
                        encoder_fusion_study.CAMPAIGN, encoder_fusion_study.RQ_CAMPAIGN,
                        free_gyro_errors.CAMPAIGN, navigation.CAMPAIGN, slew.CAMPAIGN)}


def experiment(name: str) -> ExperimentCampaign:
    """The experiment campaign called ``name``; :class:`CampaignError` naming the known ones."""
    if name not in EXPERIMENTS:
        raise CampaignError(f"experiment: unknown experiment {name!r}; known: {', '.join(sorted(EXPERIMENTS))}")
    return EXPERIMENTS[name]


#: Simulated seconds of the probe run that lists what a campaign's runs report (:func:`check_requirements`).
PROBE_S = 1.0


def plan(spec: CampaignSpec, probe: bool = True) -> CampaignPlan:
    """The runs of any campaign: its experiment's plan, or the scenario campaign's; a
    requirement on a metric its runs do not report is refused (:func:`check_requirements`;
    not ``probe``: a caller's own run function, whose metrics are its own)."""
    campaign = plan_experiment(spec, experiment(spec.experiment)) if spec.experiment else scenario_campaign.plan(spec)
    if probe:
        check_requirements(campaign)
    return campaign


def probe_metrics(campaign: CampaignPlan) -> set[str] | None:
    """The metric names (dotted, as in the results table) a run of ``campaign`` reports, from a
    :data:`PROBE_S` run of its first run on the core engine (its runner's loop for an
    experiment); None when that cannot be run (a graph-only scenario, a runner without a
    duration)."""
    first = campaign.runs[0]
    with tempfile.TemporaryDirectory(prefix="gimbal-probe-") as tmp:
        try:
            if campaign.spec.experiment and experiment(campaign.spec.experiment).run is not None:
                exp = experiment(campaign.spec.experiment)
                options = dict(campaign.fingerprint.get("options", {}))
                if "duration_s" not in options:
                    return None
                metrics = exp.run(first.variant, first.seed, {**options, "duration_s": PROBE_S})
            else:
                scenario_campaign.check_core_engine(first.scenario)
                short = dataclasses.replace(first.scenario, duration_s=min(PROBE_S, first.scenario.duration_s))
                metrics = run_on_engine(short, Path(tmp) / "probe", compress=False)
        except (CampaignError, ValueError, RuntimeError):
            return None
    return set(flatten_metrics(metrics))


def check_requirements(campaign: CampaignPlan) -> None:
    """Refuse (:class:`CampaignError`) a requirement on a metric the campaign's runs do not
    report, before any run starts."""
    if not campaign.spec.requirements or not campaign.runs:
        return
    names = probe_metrics(campaign)
    if names is None:
        return
    for req in campaign.spec.requirements:
        if req.metric not in names:
            close = difflib.get_close_matches(req.metric, sorted(names), n=5, cutoff=0.4)
            what = campaign.spec.experiment or campaign.base.name
            raise CampaignError(f"--require {req.metric}: the runs of {what!r} do not report this metric"
                                + (f"; close: {', '.join(close)}" if close else "")
                                + f" ({len(names)} metrics, e.g. {', '.join(sorted(names)[:4])})")


def runners(spec: CampaignSpec) -> Runners:
    """What the engine runs ``spec``'s tasks with: an experiment's own loop, or for a
    scenario campaign's (or a declared experiment's) ``engine: core`` the core engine, bag
    and report."""
    if spec.experiment:
        return experiment_runners(spec, experiment(spec.experiment), run_on_engine)
    return Runners(core_run=run_on_engine)


def run_campaign(spec: CampaignSpec, out_dir: Path, *, run_fn: RunFunction | None = None,
                 **options: Any) -> CampaignResult:
    """:func:`gimbal_sim.campaign.engine.run_campaign` handed the plan, runners and report of
    any campaign (an experiment's own table in its report, :func:`experiment_table`;
    ``run_fn``: a caller's own run instead); ``options`` go to the engine."""
    hooks = Runners(run_fn=run_fn) if run_fn is not None else runners(spec)
    table = partial(experiment_table, experiment(spec.experiment)) if spec.experiment else None
    report = partial(write_campaign_report, paper=campaign_paper_figure, table=table)
    return engine.run_campaign(spec, out_dir, plan=partial(plan, probe=run_fn is None), report=report, runners=hooks,
                               **options)
