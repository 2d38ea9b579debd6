"""What every experiment runner's command line shares: the campaign options it takes
(:func:`add_engine_arguments`), where its campaign goes (:func:`campaign_dir`), and its
campaign run on the engine (:func:`run_for_cli`)."""
from __future__ import annotations

import argparse
import dataclasses
import shutil
import sys
import tempfile
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Iterator

from .engine import CoreRun, Runners, run_campaign
from .experiment import ExperimentCampaign, plan_experiment, run_experiment_task
from .parsing import parse_set
from .report import write_campaign_report
from .results import CampaignResult
from .spec import CampaignError, CampaignSpec


@contextmanager
def campaign_dir(out: str | None) -> Iterator[Path]:
    """Where a runner's campaign goes: ``out`` (kept), or a temporary directory removed after
    its table is printed (print, keep nothing)."""
    if out:
        yield Path(out)
        return
    tmp = Path(tempfile.mkdtemp(prefix="gimbal-experiment-"))
    try:
        yield tmp / "campaign"
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def add_engine_arguments(ap: argparse.ArgumentParser, *, graph: bool) -> None:
    """The campaign options every runner CLI takes (argparse parser ``ap``)."""
    ap.add_argument("--engine", choices=("core", "graph") if graph else ("core",), default="core",
                    help="core: the no-ROS engine (default); graph: the real nodes through "
                         "gimbal-run (the scenario's report gives the figures)" if graph else
                         "core: this runner's own loop (no scenario's report carries this table's figures)")
    ap.add_argument("--mode", choices=("container", "processes"), default="container",
                    help="graph engine: one process for all nodes (default) or one per node")
    ap.add_argument("--jobs", type=int, default=1,
                    help="runs at once on a Dask LocalCluster on 127.0.0.1 (default 1: one by one in this process)")
    ap.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                    help="run on this Dask scheduler instead (workers on other hosts: --out on a shared file system)")
    ap.add_argument("--out", metavar="DIR", help="keep the campaign directory (runs, results.parquet, report); "
                                                 "default: a temporary one, removed after the table")
    ap.add_argument("--resume", action="store_true", help="with --out: skip the runs that have results")
    if graph:
        ap.add_argument("--set", action="append", metavar="NODE.PARAM=VALUE",
                        help="fix a parameter of the scenario's nodes in every run (a runner whose runs are a "
                             "scenario's: on either engine, or with --engine graph); repeatable")


def experiment_runners(spec: CampaignSpec, exp: ExperimentCampaign, core_run: CoreRun | None = None) -> Runners:
    """What the engine runs an experiment campaign's tasks with: the runner's own loop for
    ``engine: core``, or for a declaration (``exp.run`` None) ``core_run`` (the engine's run
    of the scenario with its bag and report); ``engine: graph`` runs are the scenario's
    (``gimbal-run``)."""
    if spec.engine != "core":
        return Runners()
    if exp.run is None:
        if core_run is None:
            raise CampaignError(f"experiment {exp.name}: its runs are scenario runs; the engine's run is needed")
        return Runners(core_run=core_run)
    return Runners(run_fn=partial(run_experiment_task, exp))


def run_for_cli(ap: argparse.ArgumentParser, args: argparse.Namespace, spec: CampaignSpec, out: Path,
                exp: ExperimentCampaign, core_run: CoreRun | None = None) -> CampaignResult:
    """Run the campaign ``spec`` of experiment ``exp`` for a runner's CLI: bad input exits 2
    naming it (through ``ap.error``), a failed run exits 1 naming it; returns the
    :class:`~.results.CampaignResult` (``core_run``: :func:`experiment_runners`)."""
    if args.jobs < 1:
        ap.error(f"--jobs must be >= 1, got {args.jobs}")
    serial = args.jobs == 1 and not args.scheduler
    try:
        spec = dataclasses.replace(spec, overrides=(*spec.overrides, *parse_set(getattr(args, "set", None)).items()))
        result = run_campaign(spec, out, plan=partial(plan_experiment, exp=exp), report=write_campaign_report,
                              runners=experiment_runners(spec, exp, core_run), resume=args.resume,
                              scheduler=args.scheduler, workers=args.jobs, serial=serial)
    except CampaignError as exc:
        ap.error(str(exc))
    if result.failed:
        for row in result.failed:
            print(f"run {row['run_id']} ({row['variant'] or '-'}, seed {row['seed']}) failed: {row['reason']}\n"
                  f"{row['log_tail']}", file=sys.stderr)
        raise SystemExit(1)
    return result
