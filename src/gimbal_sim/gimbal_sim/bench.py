"""``gimbal-bench``: benchmarks that print their figures (speed targets live here, not in tests).

``record``: the recorder's throughput and CPU share while it records a scenario run in
processes mode (one OS process per node), so its cost is measured apart from the rest.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from .scenario import ScenarioError, load


def bench_record(args: argparse.Namespace) -> int:
    import dataclasses

    from .bag.reader import scan
    from .orchestrator import run

    scenario = dataclasses.replace(load(args.scenario), duration_s=args.duration)
    with tempfile.TemporaryDirectory(prefix="gimbal-bench-") as tmp:
        out = Path(tmp) / "run"
        result = run(scenario, out, "processes", progress=False)
        contents = scan(out)
    rec = result.processes["bag_recorder"]
    rows = [
        ("scenario", f"{scenario.name}, {scenario.duration_s:g} s simulated at {scenario.sim_rate_hz:g} Hz "
                     f"(processes mode)"),
        ("wall time", f"{result.wall_s:.2f} s (real-time factor {result.real_time_factor:.2f})"),
        ("messages recorded", f"{contents.message_count} on {len(contents.topics)} topics, "
                              f"bag {'closed cleanly' if contents.closed_cleanly else 'NOT closed cleanly'}"),
        ("recorder throughput", f"{contents.message_count / result.wall_s:,.0f} msg/s wall, "
                                f"{contents.message_count / result.sim_s:,.0f} msg per simulated s"),
        ("recorder CPU", f"{rec.cpu_s:.2f} s = {100 * rec.cpu_s / result.wall_s:.1f} % of one core; "
                         f"{1e6 * rec.cpu_s / max(1, contents.message_count):.1f} us per message"),
        ("recorder at real time", f"{100 * rec.cpu_s / result.sim_s:.1f} % of one core to record the scenario's "
                                  f"rates in real time"),
        ("recorder peak RSS", f"{rec.peak_rss_mb:.0f} MiB"),
    ]
    for name, stats in sorted(result.processes.items()):
        rows.append((f"  {name}", f"CPU {stats.cpu_s:.2f} s, peak RSS {stats.peak_rss_mb:.0f} MiB"))
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}" for k, v in rows))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="gimbal-bench", description="Benchmarks that print their figures.")
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="recorder throughput and CPU share on a scenario run")
    rec.add_argument("--scenario", default="sim_open_loop", help="scenario to record (default sim_open_loop)")
    rec.add_argument("--duration", type=float, default=20.0, help="simulated seconds (default 20)")
    rec.set_defaults(func=bench_record)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ScenarioError as exc:
        print(f"gimbal-bench: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
