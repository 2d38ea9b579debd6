"""The experiment runners' Monte Carlo campaigns on the campaign engine (:mod:`.engine`).

Four runners have their own CLIs and printed tables:
``sighting_loop --monte-carlo``, ``flexure --seeds``, ``free_gyro --runs`` and
``platform_servo align``. Each is an :class:`ExperimentCampaign`: named variants (the
runner's modes or cases), a run function for ``engine: core`` (the runner's own loop, no
ROS: one seed of one variant, returning its metrics mapping), and, where a scenario's
report carries the figures its table needs, the scenario for ``engine: graph`` (real nodes
through ``gimbal-run``). An experiment that is only a declaration (``run`` None: scenario,
variants, options as scenario parameters, table) runs that scenario on the one engine for
``engine: core`` too (``gimbal_sim.core.engine_run.run_engine``: the run's bag, then its
report), so its table comes from reports over the runs' recordings. A :class:`~.spec.CampaignSpec` with ``experiment`` set is
planned here (:func:`plan_experiment`), so those runs go through the same engine as any
campaign: one Dask task per run (or serially in-process), a campaign directory with each
run's ``report/metrics.json``, ``results.parquet``, ``--resume`` and the campaign report.
The runner's table is then computed from the runs' metrics (:func:`run_metrics`).

Run ids hash the experiment name, variant, seed and options (the runner's settings), so a
run's id does not depend on the campaign it is in. Graph runs are the scenario's runs,
relabelled with the experiment's variant names; their ids are the scenario campaign's.
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..page import write_run_page
from .results import CampaignResult, read_results
from .spec import CampaignError, CampaignPlan, CampaignSpec, PlannedRun, RunTask, plan, run_id

#: core engine: (variant, seed, options) -> the run's metrics (a JSON-able mapping)
ExperimentRun = Callable[[str, int, dict[str, Any]], dict[str, Any]]


def numbered_table(summarize: Callable[[dict[str, list[tuple[int, dict]]]], str]
                   ) -> Callable[[dict[str, list[dict]]], str]:
    """A campaign's table (what its report carries) from an experiment's ``summarize`` of each
    variant's (run index, report metrics), the runs numbered in order."""
    return lambda runs: summarize({v: list(enumerate(ms)) for v, ms in runs.items()})


def duration_only(options: dict[str, Any]) -> tuple[float, tuple[tuple[str, Any], ...]]:
    """A :attr:`GraphEquivalent.translate` for runners whose only scenario-expressible option
    is the run's duration (``duration_s``)."""
    return options["duration_s"], ()


@dataclass(frozen=True)
class GraphEquivalent:
    """An experiment's runs as a scenario's: ``variants`` maps each experiment variant to
    the scenario's (None: the scenario has no variants); ``options`` names the options the
    scenario can express and ``translate(options)`` gives the run's duration [s] and its
    ``(node.param, value)`` overrides; any other option must keep its default, else the
    graph engine is refused naming it."""

    scenario: str
    variants: dict[str, str | None]
    options: tuple[str, ...] = ("duration_s",)
    translate: Callable[[dict[str, Any]], tuple[float | None, tuple[tuple[str, Any], ...]]] = duration_only


@dataclass(frozen=True)
class ExperimentCampaign:
    """One runner's Monte Carlo (module docstring). ``defaults``: every option and its default
    (the options a run takes); ``run`` must be a module-level function (Dask pickles it)."""

    name: str
    variants: tuple[str, ...]
    defaults: dict[str, Any]
    #: None: a declaration, whose runs are ``graph``'s scenario on either engine
    run: ExperimentRun | None
    graph: GraphEquivalent | None = None
    #: the variants run when none is named (None: all); the others only with --variant
    default_variants: tuple[str, ...] | None = None
    #: the runner's own table from each variant's run metrics (metrics.json mappings), which
    #: ``gimbal-campaign`` prints and the campaign report carries (:func:`experiment_table`)
    table: Callable[[dict[str, list[dict[str, Any]]]], str] | None = None


def _options(exp: ExperimentCampaign, given: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    options = dict(exp.defaults)
    for key, value in given:
        if key not in options:
            raise CampaignError(f"experiment {exp.name}: unknown option {key!r}; options: {sorted(options)}")
        options[key] = value
    return options


def plan_experiment(spec: CampaignSpec, exp: ExperimentCampaign) -> CampaignPlan:
    """The :class:`~.spec.CampaignPlan` of the experiment campaign ``spec`` of ``exp``
    (``spec.experiment`` names it): variant × seed runs of the runner's core loop, or
    (``engine: graph``, or any engine of a declaration) the runs of its scenario relabelled
    with the experiment's variant names."""
    if spec.experiment != exp.name:
        raise CampaignError(f"experiment: campaign of {spec.experiment!r} given experiment {exp.name!r}")
    if spec.sweeps:
        raise CampaignError(f"experiment {exp.name}: sweeps are for scenario campaigns; its settings are options")
    variants = spec.variants or exp.default_variants or exp.variants
    for name in variants:
        if name not in exp.variants:
            raise CampaignError(f"experiment {exp.name}: no variant {name!r}; variants: {', '.join(exp.variants)}")
    options = _options(exp, spec.options)
    fingerprint = {"experiment": exp.name, "engine": spec.engine, "options": options,
                   "mode": spec.mode if spec.engine == "graph" else None, **spec.review_dict()}
    if spec.engine == "core" and exp.run is not None:
        if spec.overrides:
            graph = " (--engine graph runs its scenario)" if exp.graph is not None else ""
            raise CampaignError(f"experiment {exp.name}: --set sets a scenario's parameter; its core engine is its "
                                f"own loop, which takes options{graph}")
        runs = tuple(PlannedRun(run_id(exp.name, v, seed, options), v, seed, {}, None)
                     for seed in spec.seeds for v in variants)
        return CampaignPlan(spec, None, runs, fingerprint)
    graph = exp.graph
    if graph is None:
        raise CampaignError(f"experiment {exp.name}: no scenario's report carries its table's figures; "
                            "--engine graph is not available (use core)")
    return _scenario_plan(spec, exp, graph, variants, options, fingerprint)


def _scenario_plan(spec: CampaignSpec, exp: ExperimentCampaign, graph: GraphEquivalent, variants: tuple[str, ...],
                   options: dict[str, Any], fingerprint: dict[str, Any]) -> CampaignPlan:
    """The runs of ``graph``'s scenario on ``spec``'s engine, relabelled with the
    experiment's variant names (:func:`plan_experiment`)."""
    missing = [v for v in variants if v not in graph.variants]
    if missing:
        raise CampaignError(f"experiment {exp.name}: variant(s) {missing} have no variant of scenario "
                            f"{graph.scenario!r}; --engine {spec.engine} runs {sorted(graph.variants)}")
    fixed = [k for k, v in options.items() if k not in graph.options and v != exp.defaults[k]]
    if fixed:
        raise CampaignError(f"experiment {exp.name}: option(s) {fixed} have no equivalent in scenario "
                            f"{graph.scenario!r}; --engine {spec.engine} takes only {sorted(graph.options)}")
    duration, overrides = graph.translate(options)
    clash = sorted({t for t, _ in overrides} & {t for t, _ in spec.overrides})
    if clash:
        raise CampaignError(f"experiment {exp.name}: --set {', '.join(clash)}: an option of the experiment sets it")
    overrides = (*overrides, *spec.overrides)
    scenario_variants = tuple(graph.variants[v] for v in variants if graph.variants[v] is not None)
    inner = plan(CampaignSpec(scenario=graph.scenario, seeds=spec.seeds, variants=scenario_variants,
                              duration_s=duration, mode=spec.mode, engine=spec.engine, overrides=overrides,
                              keep_bags=spec.keep_bags, timeout_s=spec.timeout_s, compress=spec.compress))
    label = {graph.variants[v] or "": v for v in variants}
    runs = tuple(dataclasses.replace(r, variant=label[r.variant]) for r in inner.runs)
    return CampaignPlan(spec, inner.base, runs, {**fingerprint, **inner.fingerprint, "options": options})


def run_experiment_task(exp: ExperimentCampaign, task: RunTask, run_dir: Path) -> dict[str, Any]:
    """The campaign engine's run function for ``engine: core`` runs of ``exp`` (picklable as
    ``functools.partial(run_experiment_task, exp)``): the runner's loop for the task's
    variant, seed and options; writes ``report/metrics.json``, ``run.json`` and the run's
    page ``report/index.html`` into ``run_dir`` (the campaign report rewrites the page with
    the paper's figures and the link to the campaign, once the run is in its place)."""
    metrics = exp.run(task.variant, task.seed, dict(task.options))
    (run_dir / "report").mkdir(parents=True, exist_ok=True)
    (run_dir / "report" / "metrics.json").write_text(json.dumps(metrics, indent=1, default=float) + "\n")
    (run_dir / "run.json").write_text(json.dumps({"experiment": exp.name, "engine": "core", "variant": task.variant,
                                                  "seed": task.seed, "options": task.options}, default=repr) + "\n")
    write_run_page(run_dir, run_dir / "report", metrics)
    return metrics


def run_metrics(result: CampaignResult) -> dict[str, list[tuple[int, dict[str, Any]]]]:
    """Each variant's [(seed, metrics.json mapping)] of a finished campaign, in plan order.
    Raises RuntimeError naming the failed runs (a runner's table needs every run)."""
    failed = result.failed
    if failed:
        raise RuntimeError("; ".join(f"run {r['run_id']} ({r['variant'] or '-'}, seed {r['seed']}) failed: "
                                     f"{r['reason']}" for r in failed))
    out: dict[str, list[tuple[int, dict[str, Any]]]] = {}
    for row in result.rows:
        path = Path(result.directory) / "runs" / row["run_id"] / "report" / "metrics.json"
        if not path.is_file():  # a worker on another host wrote it on its own disk
            raise RuntimeError(f"run {row['run_id']} ran on {row['host']}: its metrics.json is not in {path.parent}; "
                               "with workers on other hosts, give --out on a file system they share")
        out.setdefault(row["variant"], []).append((int(row["seed"]), json.loads(path.read_text())))
    return out


def experiment_table(exp: ExperimentCampaign, campaign_dir: Path) -> str | None:
    """``exp.table`` of the campaign in ``campaign_dir``: its ok runs' ``metrics.json`` per
    variant, in the results' order (a failed run is left out; the report lists it). None
    when ``exp`` has no table or no run is ok."""
    if exp.table is None:
        return None
    runs: dict[str, list[dict[str, Any]]] = {}
    for row in read_results(Path(campaign_dir)):
        path = Path(campaign_dir) / "runs" / row["run_id"] / "report" / "metrics.json"
        if row["status"] == "ok" and path.is_file():
            runs.setdefault(row["variant"], []).append(json.loads(path.read_text()))
    return exp.table(runs) if runs else None
