"""``gimbal-campaign``: Monte Carlo and parameter sweeps of a scenario on Dask.

    gimbal-campaign sighting_land_vehicle --seeds 1-20 --mode container --out bags/mc20
    gimbal-campaign sighting_land_vehicle --variant ekf_on --seeds 1-5 \\
        --sweep sensor_models.gimbal_gyro_bias_deg_h=50:200:4 --duration 60
    gimbal-campaign campaign.yaml --scheduler tcp://10.0.0.5:8786     # an existing cluster
    gimbal-campaign --out bags/mc20 --resume                          # finish / extend it
    gimbal-campaign diff bags/mc20 bags/mc20_core --prefix sighting.  # two campaigns' metrics
    gimbal-campaign sighting_land_vehicle --variant ekf_off --duration 30 --engine core \
        --disperse 'sensor_models.gimbal_gyro_bias_deg_h[0]=normal(0, 200)' --sensitivity sobol --samples 32
    gimbal-campaign rotational_ins_navigation --variant rotation_on --seeds 1-22 \
        --require 'navigation.radial_rate_nmi_h<=0.5,p=0.9,c=0.9'   # a verdict; exit 3 unless met

The campaign comes from a YAML file (:mod:`gimbal_sim.campaign.spec` documents it) and/or flags (a
flag overrides the file). Without ``--scheduler`` an embedded LocalCluster on 127.0.0.1
runs one single-threaded worker process per core. The campaign directory holds
``campaign.yaml``, ``runs/<id>/``, ``results.parquet`` (+ csv) and ``report/``.

Exit codes: 0 every run ok (and every requirement met); 1 a run failed (the others still
ran; each failure is in the results with its reason); 3 a requirement not met, or too few
runs to judge it (the verdicts head the output and the report); 2 bad input (unknown scenario, variant or parameter, malformed
range, unreachable scheduler, existing directory without --resume), nothing started; 130
Ctrl-C (the runs that finished are tabulated and reported; --resume runs the rest).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from gimbal_kinematics.cli.boundary import cli_boundary, finite, read_text, writable_dir

from .campaign.parsing import parse_assignments, parse_set
from .campaign.report import diff_results
from .campaign.dispersion import SAMPLINGS as DISPERSION_SAMPLINGS
from .campaign.sensitivity import METHODS as SENSITIVITY_METHODS
from .campaign.spec import ENGINES, KEEP_BAGS, LARGE_RUNS, MODES, SAMPLINGS, CampaignError, CampaignSpec, \
    is_record, load_spec_file, parse_requirements, parse_seeds, spec_from_mapping
from .experiments.registry import EXPERIMENTS, run_campaign


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gimbal-campaign", description=__doc__.split("\n\n")[0].split(": ", 1)[1],
                                epilog="`gimbal-campaign diff A B` pairs two campaigns' runs by seed: each metric's largest "
                                       "difference and its change with a paired 95 % interval.")
    p.add_argument("campaign", nargs="?", help="a campaign YAML file, or a scenario (built-in name or scenario YAML)")
    p.add_argument("--variant", action="append", metavar="NAME", help="run this variant (repeatable; default all)")
    p.add_argument("--seeds", help="seeds, e.g. 1-20 or 1,3,5-7 (default: the file's, else 0)")
    p.add_argument("--sweep", action="append", metavar="NODE.PARAM=SPEC",
                   help="sweep a node parameter: a:b:n (grid), v1,v2,... (list), a:b (bounds, --sampling sobol); "
                        "NODE.PARAM[i] sweeps one element of a vector parameter; repeatable")
    p.add_argument("--sampling", choices=SAMPLINGS, help="grid: every combination; sobol: --samples scrambled "
                   "Sobol points in the sweeps' bounds (scipy.stats.qmc)")
    p.add_argument("--samples", type=int, metavar="N", help="Sobol points (a power of 2); with --sensitivity the "
                   "design's N (sobol: a power of 2; morris: trajectories)")
    p.add_argument("--sample-seed", type=int, metavar="N", help="seed of the Sobol scrambling, the dispersions' "
                   "sampling and the sensitivity design (default 0)")
    p.add_argument("--set", action="append", metavar="NODE.PARAM=VALUE", help="fix a node parameter in every run "
                   "(prelude.NODE.PARAM: a parameter of each run's prelude)")
    p.add_argument("--disperse", action="append", metavar="NODE.PARAM=DIST",
                   help="draw a node parameter per run: normal(mean, std), truncnormal(mean, std, low, high), "
                        "uniform(low, high) or choice(v1: w1, v2: w2); NODE.PARAM[i] one element; repeatable")
    p.add_argument("--dispersion-sampling", choices=DISPERSION_SAMPLINGS,
                   help="how the draws cover the distributions: random (default), lhs (Latin hypercube) or sobol "
                        "(a power of 2 of seeds); seeded by --sample-seed")
    p.add_argument("--require", action="append", metavar="METRIC<=BOUND,p=P,c=C",
                   help="a requirement: METRIC (|METRIC| for its magnitude) <= (or >=) BOUND in a fraction P of "
                        "the runs at confidence C; judged by order statistics (Wilks); exit 3 unless met; repeatable")
    p.add_argument("--sensitivity", choices=SENSITIVITY_METHODS,
                   help="sobol: a Saltelli design of --samples N (a power of 2) x (dispersions + 3) runs, first-order "
                        "and total indices; morris: --samples trajectories, elementary effects; the seed is a factor")
    p.add_argument("--duration", type=float, metavar="S", help="simulated seconds per run (default: the scenario's)")
    p.add_argument("--mode", choices=MODES, help="graph engine: all nodes in one process (container, default) or "
                   "one process per node")
    p.add_argument("--engine", choices=ENGINES, help="graph: the real nodes through gimbal-run (default); core: "
                   "the same cores in one Python loop, no ROS")
    p.add_argument("--keep-bags", choices=KEEP_BAGS, help="keep every run's bag (all, default), only failed runs' "
                   "or none (each run keeps its metrics and report)")
    p.add_argument("--no-bags", action="store_true", help="keep no run's bag (--keep-bags none); by default every "
                   "run keeps its zstd-compressed bag, on either engine, so every figure can be recomputed from them")
    p.add_argument("--no-compress", action="store_true", help="uncompressed MCAP chunks in the bags")
    p.add_argument("--timeout", type=float, metavar="S", help="a run taking longer fails (default 120 + 10 x duration)")
    p.add_argument("--out", type=Path, help="campaign directory (default bags/campaigns/<time>_<scenario>)")
    p.add_argument("--resume", action="store_true", help="continue the campaign in --out: runs with results are "
                   "skipped, failed ones run again")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="use this Dask scheduler instead of a LocalCluster")
    p.add_argument("--workers", type=int, metavar="N", help="LocalCluster worker processes (default: the cores)")
    p.add_argument("--serial", action="store_true", help="run the tasks one by one in this process (no Dask)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--large", action="store_true",
                   help=f"allow a campaign of more than {LARGE_RUNS:,} runs, or one it estimates to take over 24 h")
    return p


def _is_campaign_file(text: str) -> bool:
    path = Path(text)
    if path.suffix not in (".yaml", ".yml") or not path.is_file():
        return False
    try:
        data = yaml.safe_load(read_text(path, "campaign file"))
    except yaml.YAMLError:
        return False
    return is_record(data) or (isinstance(data, dict) and ("scenario" in data or "experiment" in data)
                               and "nodes" not in data)


def _experiment_spec(args: argparse.Namespace) -> CampaignSpec:
    """An experiment runner's campaign named like its scenario (``rotational_ins_navigation``):
    the runner's own loop (``--engine core``, the default) or the scenario's nodes."""
    for flag in ("sweep", "sampling", "samples", "disperse", "sensitivity"):
        if getattr(args, flag):
            raise CampaignError(f"--{flag}: experiment {args.campaign} takes seeds, variants, --duration, --engine, "
                                f"--set and --require")
    options = (("duration_s", float(args.duration)),) if args.duration is not None else ()
    return CampaignSpec(scenario="", experiment=args.campaign, seeds=parse_seeds(args.seeds or "0", "--seeds"),
                        variants=tuple(args.variant or ()), engine=args.engine or "core",
                        mode=args.mode or "container", options=options,
                        overrides=tuple(parse_set(args.set).items()),
                        requirements=parse_requirements(args.require, "--require"))


def spec_from_args(args: argparse.Namespace) -> CampaignSpec | None:
    """The campaign the flags (and file) ask for; None for a bare ``--resume --out DIR``."""
    data: dict[str, Any] = {}
    if args.campaign and not _is_campaign_file(args.campaign) and args.campaign in EXPERIMENTS \
            and EXPERIMENTS[args.campaign].graph is not None and EXPERIMENTS[args.campaign].graph.scenario == args.campaign:
        return _experiment_spec(args)
    if args.campaign and _is_campaign_file(args.campaign):
        data = load_spec_file(Path(args.campaign)).to_dict()
    elif args.campaign:
        data["scenario"] = args.campaign
    elif args.resume and args.out is not None and (args.out / "campaign.yaml").is_file():
        data = (yaml.safe_load(read_text(args.out / "campaign.yaml", "--resume")) or {}).get("campaign", {})
    else:
        raise CampaignError("no campaign: give a scenario or a campaign YAML file (or --resume --out DIR)")
    for flag, key in (("seeds", "seeds"), ("sampling", "sampling"), ("samples", "samples"),
                      ("sample_seed", "sample_seed"), ("duration", "duration_s"), ("mode", "mode"),
                      ("engine", "engine"), ("keep_bags", "keep_bags"), ("timeout", "timeout_s"),
                      ("dispersion_sampling", "dispersion_sampling"), ("sensitivity", "sensitivity")):
        value = getattr(args, flag)
        if value is not None:
            data[key] = value
    if args.variant:
        data["variants"] = list(args.variant)
    if args.no_compress:
        data["compress"] = False
    if args.no_bags:
        if args.keep_bags not in (None, "none"):
            raise CampaignError(f"--no-bags contradicts --keep-bags {args.keep_bags}")
        data["keep_bags"] = "none"
    if args.sweep:
        data["sweep"] = parse_assignments(args.sweep, "--sweep")
    if args.disperse:
        data["dispersions"] = parse_assignments(args.disperse, "--disperse")
    if args.require:
        data["requirements"] = list(args.require)
    if args.set:
        data["set"] = {**(data.get("set") or {}), **parse_set(args.set)}
    return spec_from_mapping(data, "campaign")


def _diff(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="gimbal-campaign diff",
                                description="Compare two campaigns' metrics on their runs paired by seed (and swept values, "
                                            "and variant when both have the same variants): max |a - b| and the "
                                            "paired change b - a with its 95 % Student t interval, significant "
                                            "when the interval excludes 0.")
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    p.add_argument("--prefix", default="", help="only metrics whose name starts with this (e.g. sighting.)")
    p.add_argument("--tol", type=float, default=0.0, help="exit 1 when a metric differs by more (default 0)")
    args = p.parse_args(argv)
    for d in (args.a, args.b):
        if not (d / "results.parquet").is_file():
            print(f"gimbal-campaign diff: {d}: no results.parquet; not a campaign directory", file=sys.stderr)
            return 2
    out = diff_results(args.a, args.b, args.prefix)
    print(f"{out['shared_runs']} runs in both, paired by {out['paired_by']} ({out['only_a']} only in {args.a}, "
          f"{out['only_b']} only in {args.b})")
    width = max((len(k) for k in out["metrics"]), default=0)
    worst = 0.0
    for name, m in out["metrics"].items():
        worst = max(worst, m["max_abs_diff"])
        nan = "" if m["nonfinite_agree"] else "  (NaN in one only!)"
        change = ""
        if m.get("pairs", 0) >= 2:
            lo, hi = m["interval"]
            change = (f"; b - a {m['mean_change']:+.4g} [{lo:+.4g}, {hi:+.4g}] (paired t, 95 %): "
                      f"{'SIGNIFICANT' if m['significant'] else 'not significant'}")
        print(f"  {name:<{width}}  max |a - b| {m['max_abs_diff']:.3g} over {m['runs']} runs{nan}{change}")
    ok = worst <= args.tol and all(m["nonfinite_agree"] for m in out["metrics"].values())
    print(f"largest difference {worst:.3g}: {'within' if ok else 'ABOVE'} tolerance {args.tol:g}")
    return 0 if ok and out["shared_runs"] else 1


@cli_boundary("gimbal-campaign", interrupted="stopped the campaign; the runs that finished are in its directory; "
                                         "--resume --out DIR continues it")
def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "diff":
        return _diff(argv[1:])
    args = build_parser().parse_args(argv)
    if args.resume and args.out is None:
        raise CampaignError("--resume needs --out DIR (the campaign to continue)")
    if args.resume and not args.out.is_dir():
        raise CampaignError(f"--resume: {args.out}: no such campaign directory; without --resume a new one starts")
    for option in ("duration", "timeout"):
        if getattr(args, option) is not None:
            finite(getattr(args, option), f"--{option}", 0.0, strict=True)
    spec = spec_from_args(args)
    if args.workers is not None and args.workers < 1:
        raise CampaignError(f"--workers must be >= 1, got {args.workers}")
    if args.scheduler and (args.serial or args.workers):
        raise CampaignError("--scheduler uses that cluster's workers: drop --serial / --workers")
    out = args.out or Path("bags") / "campaigns" / f"{time.strftime('%Y%m%d-%H%M%S')}_{spec.experiment or Path(spec.scenario).stem}"
    if not args.resume and not out.exists():
        writable_dir(out, "--out")
    result = run_campaign(spec, out, resume=args.resume, scheduler=args.scheduler, workers=args.workers,
                          serial=args.serial, progress=not args.no_progress, large=args.large)
    summary = json.loads((result.directory / "report" / "summary.json").read_text())
    print(summary.get("table", ""))
    print(f"campaign {result.directory}: {result.ran} runs ran, {result.skipped} had results, "
          f"{len(result.failed)} failed; wall time {result.wall_s:.1f} s")
    print(f"results {result.directory / 'results.parquet'}, report {result.directory / 'report'}")
    unmet = [v for v in summary.get("requirements", []) if v["verdict"] != "met"]
    for v in unmet:
        print(f"requirement {v['requirement']} [{v['group']}]: {v['verdict']} ({v['detail']})", file=sys.stderr)
    return 1 if result.failed else (3 if unmet else 0)


if __name__ == "__main__":
    sys.exit(main())
