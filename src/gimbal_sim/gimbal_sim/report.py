"""Reports from recorded bags: ``report/metrics.json`` plus PNG plots.

``gimbal-report DIR`` regenerates the report of any bag; the orchestrator writes it at the
end of each run. Every figure comes from the bag itself, decoded from the recorded bytes.
The reports themselves live in :mod:`.reports`, one module each; ``generic`` works for any
run.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import yaml

from .bag.reader import BagError
from .reports import REPORTS, report_function


def write_report(bag_dir: Path, name: str | None = None) -> tuple[Path, dict]:
    """Write ``<bag_dir>/report/`` with the scenario's report (from ``scenario.yaml`` when
    ``name`` is None); returns the report directory and its metrics."""
    bag_dir = Path(bag_dir)
    if name is None:
        scenario_file = bag_dir / "scenario.yaml"
        name = yaml.safe_load(scenario_file.read_text()).get("report", "generic") if scenario_file.is_file() \
            else "generic"
    if name not in REPORTS:
        raise BagError(f"unknown report {name!r}; known: {', '.join(sorted(REPORTS))}")
    out = bag_dir / "report"
    out.mkdir(exist_ok=True)
    metrics = report_function(name)(bag_dir, out)
    metrics["report"] = name
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float) + "\n")
    return out, metrics


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="gimbal-report",
        description="Write (or rewrite) the report of a recorded run: DIR/report/metrics.json and PNG plots, "
                    "computed from the bag alone.")
    parser.add_argument("bag", help="bag directory (a gimbal-run output or any rosbag2 MCAP bag)")
    parser.add_argument("--report", help=f"report to write (default: the run's own); one of {sorted(REPORTS)}")
    args = parser.parse_args(argv)
    try:
        out, metrics = write_report(Path(args.bag), args.report)
    except BagError as exc:
        print(f"gimbal-report: {exc}", file=sys.stderr)
        return 2
    print(f"report written to {out} ({len(metrics.get('plots', []))} plots)")
    if not metrics.get("closed_cleanly", True):
        print(f"warning: the bag was not closed cleanly: {metrics.get('read_error')}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
