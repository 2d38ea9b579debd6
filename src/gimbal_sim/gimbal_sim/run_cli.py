"""``gimbal-run``: the launch-free scenario orchestrator's entry point.

Exit codes: 0 success; 1 the run failed (a node died or stalled; the bag is still
finalized); 2 bad input (unknown scenario or node, malformed --set, output exists), with
nothing started and nothing overwritten.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from .scenario import ScenarioError, apply_set, describe_builtins, load


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-run",
        description=(
            "Run a stabilized-sighting-platform scenario: start its nodes in lockstep, record "
            "every topic to a rosbag2 MCAP bag and write a report (metrics.json + plots). "
            "Without SCENARIO, list the built-in ones."),
    )
    parser.add_argument("scenario", nargs="?", help="built-in scenario name or scenario YAML file")
    parser.add_argument("--list", action="store_true", help="list the built-in scenarios and exit")
    parser.add_argument("--duration", type=float, metavar="S", help="simulated duration [s]")
    parser.add_argument("--seed", type=int, help="seed of every random stream")
    parser.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                        help="override a node parameter (value in YAML syntax); repeatable")
    parser.add_argument("--out", type=Path, help="run directory (default bags/<timestamp>_<scenario>)")
    parser.add_argument("--mode", choices=("processes", "container"), default="processes",
                        help="one OS process per node, or all nodes in this process (default processes)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def _print_list() -> None:
    builtins = describe_builtins()
    print("Built-in scenarios:")
    width = max((len(n) for n, _ in builtins), default=0)
    for name, text in builtins:
        print(f"  {name:<{width}}  {text}")


def summary_table(rows: list[tuple[str, str]]) -> str:
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.list or args.scenario is None:
        _print_list()
        return 0
    try:
        scenario = load(args.scenario)
        if args.duration is not None:
            if not args.duration > 0:
                raise ScenarioError(f"--duration must be > 0, got {args.duration}")
            scenario = dataclasses.replace(scenario, duration_s=args.duration)
        if args.seed is not None:
            if args.seed < 0:
                raise ScenarioError(f"--seed must be >= 0, got {args.seed}")
            scenario = dataclasses.replace(scenario, seed=args.seed)
        for assignment in args.set:
            scenario = apply_set(scenario, assignment)
    except ScenarioError as exc:
        print(f"gimbal-run: {exc}", file=sys.stderr)
        return 2
    out = args.out or Path("bags") / f"{time.strftime('%Y%m%d-%H%M%S')}_{scenario.name}"
    if out.exists():
        print(f"gimbal-run: output directory {out} already exists; not overwriting it", file=sys.stderr)
        return 2

    from .orchestrator import RunError, run
    from .report import write_report

    try:
        result = run(scenario, out, args.mode, progress=not args.no_progress)
    except RunError as exc:
        print(f"gimbal-run: run failed: {exc}\nThe bag so far is in {out}.", file=sys.stderr)
        return 1
    report_dir, metrics = write_report(out)
    print(summary_table([
        ("scenario", f"{scenario.name} ({args.mode} mode, seed {scenario.seed})"),
        ("simulated", f"{result.sim_s:.3f} s at {scenario.sim_rate_hz:g} Hz"),
        ("wall time", f"{result.wall_s:.2f} s (real-time factor {result.real_time_factor:.2f})"),
        ("recorded", f"{metrics['message_count']} messages on {len(metrics['topics'])} topics, "
                     f"{'closed cleanly' if metrics['closed_cleanly'] else 'NOT closed cleanly'}"),
        ("bag", str(out)),
        ("report", f"{report_dir}/metrics.json + {len(metrics.get('plots', []))} plots"),
    ]))
    return 0 if metrics["closed_cleanly"] else 1


if __name__ == "__main__":
    sys.exit(main())
