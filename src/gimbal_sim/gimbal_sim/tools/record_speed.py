"""``gimbal-bench record``: what recording costs the graph's recorder, with and without zstd
chunks (one processes-mode run each): wall time, messages, bag size, the recorder's CPU and
peak RSS."""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

from ..bag.reader import find_mcap, scan
from ..graph.orchestrator import run
from ..graph.scenario import Scenario, load


def note(text: str) -> None:
    """One progress line per phase on stderr (no bars: a benchmark takes minutes, not hours)."""
    print(f"gimbal-bench: {text}", file=sys.stderr, flush=True)


def _record_once(scenario: Scenario, compress: bool) -> dict[str, str]:
    """One processes-mode run recorded with or without zstd chunks: the recorder's figures."""
    with tempfile.TemporaryDirectory(prefix="gimbal-bench-") as tmp:
        out = Path(tmp) / "run"
        result = run(scenario, out, "processes", progress=False, compress=compress)
        if result.interrupted:
            raise KeyboardInterrupt("stopped the recorder benchmark; nothing was kept")
        contents = scan(out)
        size = find_mcap(out)[0].stat().st_size
    rec = result.processes["bag_recorder"]
    rec_cpu = rec.cpu_s - result.cpu_at_start.get("bag_recorder", 0.0)
    return {
        "wall time": f"{result.wall_s:.2f} s (real-time factor {result.real_time_factor:.2f})",
        "messages recorded": f"{contents.message_count} on {len(contents.topics)} topics, "
                             f"{'closed cleanly' if contents.closed_cleanly else 'NOT closed cleanly'}",
        "bag size": f"{size / 2**20:.1f} MiB ({size / max(1, contents.message_count):.0f} B per message)",
        "recorder throughput": f"{contents.message_count / result.wall_s:,.0f} msg/s wall",
        "recorder CPU": f"{rec_cpu:.2f} s while stepping = {100 * rec_cpu / result.wall_s:.1f} % of one core; "
                        f"{1e6 * rec_cpu / max(1, contents.message_count):.1f} us per message",
        "recorder at real time": f"{100 * rec_cpu / result.sim_s:.1f} % of one core for the scenario's rates "
                                 f"in real time",
        "recorder peak RSS": f"{rec.peak_rss_mb:.0f} MiB",
        "other processes CPU": ", ".join(f"{name} {st.cpu_s:.2f} s" for name, st in sorted(result.processes.items())
                                         if name != "bag_recorder"),
    }


def bench_record(args: argparse.Namespace) -> int:
    scenario = dataclasses.replace(load(args.scenario), duration_s=args.duration)
    settings = {"both": (True, False), "on": (True,), "off": (False,)}[args.compress]
    columns = {}
    for compress in settings:
        note(f"recording {scenario.name} ({scenario.duration_s:g} s, processes mode), compression "
              f"{'on (zstd chunks)' if compress else 'off'} ...")
        columns["zstd chunks" if compress else "uncompressed"] = _record_once(scenario, compress)
    print(f"scenario: {scenario.name}, {scenario.duration_s:g} s simulated at {scenario.sim_rate_hz:g} Hz "
          f"(processes mode)")
    names = list(next(iter(columns.values())))
    width = max(len(k) for k in names)
    for name in names:
        for label, values in columns.items():
            print(f"{name:<{width}}  [{label}] {values[name]}")
    return 0
