"""``gimbal-report``'s dispatch: a run's ``report/metrics.json`` plus PNG plots.

``gimbal-report DIR`` regenerates the report of any bag (``gimbal-run`` writes it at the
end of each run), the comparison of a run with variants, or a campaign's reports. Every
figure comes from the bag itself, decoded from the recorded bytes. The reports live in
this package, one module each (:data:`gimbal_sim.reports.REPORTS`); ``generic`` works for
any run.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import yaml

from gimbal_kinematics.cli.boundary import cli_boundary, read_text

from ..bag.checks import damage_warnings
from ..bag.reader import BagError, require_messages, scan
from ..campaign.report import regenerate
from ..page import write_comparison_page, write_run_page
from . import COMPARISONS, REPORTS, comparison_function, report_function
from .paper import campaign_paper_figure, comparison_paper_lookup, run_paper_lookup


def write_comparison(run_dir: Path, name: str, runs: dict[str, Path]) -> tuple[Path, dict]:
    """Write ``<run_dir>/report/`` with the comparison ``name`` of the variant bags ``runs``."""
    if name not in COMPARISONS:
        raise BagError(f"unknown comparison {name!r}; known: {', '.join(sorted(COMPARISONS)) or 'none'}")
    out = Path(run_dir) / "report"
    out.mkdir(parents=True, exist_ok=True)
    metrics = comparison_function(name)({k: Path(v) for k, v in runs.items()}, out)
    metrics["comparison"] = name
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float) + "\n")
    write_comparison_page(run_dir, out, metrics, runs, comparison_paper_lookup(Path(run_dir) / "scenario.yaml"),
                          run_paper_lookup)
    return out, metrics


def _variant_runs(run_dir: Path) -> tuple[str, dict[str, Path]] | None:
    """(comparison, runs) when ``run_dir`` holds the variant runs of one scenario."""
    scenario_file = run_dir / "scenario.yaml"
    if (run_dir / "metadata.yaml").is_file() or not scenario_file.is_file():
        return None
    data = yaml.safe_load(read_text(scenario_file, "scenario file")) or {}
    runs = {name: run_dir / name for name in data.get("variants") or {} if (run_dir / name).is_dir()}
    return (str(data.get("comparison", "")), runs) if runs else None


def write_report(bag_dir: Path, name: str | None = None) -> tuple[Path, dict]:
    """Write ``<bag_dir>/report/`` with the scenario's report (from ``scenario.yaml`` when
    ``name`` is None); returns the report directory and its metrics."""
    bag_dir = Path(bag_dir)
    if not bag_dir.is_dir():
        raise BagError(f"{bag_dir}: " + ("a file; give the bag's directory (the report goes into DIR/report/)"
                                         if bag_dir.exists() else "no such directory"))
    require_messages(bag_dir)
    if name is None:
        scenario_file = bag_dir / "scenario.yaml"
        name = (yaml.safe_load(read_text(scenario_file, "scenario file")) or {}).get("report", "generic") \
            if scenario_file.is_file() else "generic"
    if name not in REPORTS:
        raise BagError(f"unknown report {name!r}; known: {', '.join(sorted(REPORTS))}")
    out = bag_dir / "report"
    created = not out.exists()
    out.mkdir(exist_ok=True)
    try:
        metrics = report_function(name)(bag_dir, out)
        metrics["report"] = name
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float) + "\n")
        write_run_page(bag_dir, out, metrics, run_paper_lookup(bag_dir / "scenario.yaml"))
    except BaseException:
        if created:  # a report that failed leaves no folder that looks like one
            shutil.rmtree(out, ignore_errors=True)
        raise
    return out, metrics


def _campaign_main(campaign_dir: Path) -> int:
    """A campaign directory: its runs' reports from their bags, then the campaign report."""
    try:
        out, summary = regenerate(campaign_dir, write_report, campaign_paper_figure)
    except (BagError, OSError, ValueError) as exc:
        print(f"gimbal-report: {campaign_dir}: {exc}", file=sys.stderr)
        return 2
    print(summary["table"])
    print(f"campaign report written to {out} ({len(summary['plots'])} plots)")
    print(f"page: {out / 'index.html'}")
    return 0


@cli_boundary("gimbal-report")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="gimbal-report",
        description="Write (or rewrite) the report of a recorded run: DIR/report/metrics.json and PNG plots, "
                    "computed from the bag alone.")
    parser.add_argument("bag", help="bag directory (a gimbal-run output or any rosbag2 MCAP bag), the "
                                    "directory of a run with variants (rewrites each variant's report and "
                                    "the comparison), or a gimbal-campaign directory (rewrites each kept "
                                    "run's report, results.parquet and the campaign report)")
    parser.add_argument("--report", help=f"report to write (default: the run's own); one of {sorted(REPORTS)}")
    args = parser.parse_args(argv)
    if args.report is None and (Path(args.bag) / "campaign.yaml").is_file():
        return _campaign_main(Path(args.bag))
    try:
        variants = _variant_runs(Path(args.bag)) if args.report is None else None
        if variants is not None:
            for bag in variants[1].values():
                write_report(bag)
            out, metrics = write_comparison(Path(args.bag), *variants)
            if metrics.get("table"):
                print(metrics["table"])
        else:
            out, metrics = write_report(Path(args.bag), args.report)
    except BagError as exc:
        print(f"gimbal-report: {exc}", file=sys.stderr)
        return 2
    print(f"report written to {out} ({len(metrics.get('plots', []))} plots)")
    print(f"page: {out / 'index.html'}")
    if not metrics.get("closed_cleanly", True):
        why = metrics.get("read_error") or "no metadata.yaml (the recording was not finalized)"
        print(f"warning: the bag was not closed cleanly: {why}", file=sys.stderr)
        if metrics.get("read_error") and variants is None:  # each damaged part, as every bag command says it
            for line in damage_warnings(scan(Path(args.bag))):
                print(line, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
