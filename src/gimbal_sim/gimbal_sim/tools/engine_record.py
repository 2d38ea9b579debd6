"""What recording its bag costs the engine: a scenario stepped unrecorded
(:func:`..core.core_loop.run_core_loop`) and recorded (:func:`..core.engine_run.run_engine`,
run files, bag and run.json), alternately ``--pairs`` times; the best of each, their ratio
against the target (≤ 3×), and the bag's size. Also the stepping thread's CPU time of each
(the bag's chunks are compressed and written on a thread of their own): the wall ratio a
machine with a core free for that thread gives; on a loaded machine the wall ratio is worse.

``python -m gimbal_sim.tools.engine_record [--scenario S] [--variant V] [--duration S] [--pairs N]``
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

from gimbal_kinematics.cli.boundary import cli_boundary, finite

from ..core.core_loop import run_core_loop
from ..core.engine_run import check_engine, run_engine
from ..graph.scenario import load, variant

#: recording may make the engine at most this many times slower
TARGET_RATIO = 3.0


def measure(scenario, pairs: int) -> dict:
    """Best unrecorded and recorded wall times [s] over ``pairs`` alternating runs, and the bag."""
    check_engine(scenario)
    plain, recorded, plain_cpu, recorded_cpu, size, messages = [], [], [], [], 0, 0
    with tempfile.TemporaryDirectory(prefix="engine_record_") as tmp:
        for i in range(pairs):
            c0 = time.thread_time()
            plain.append(run_core_loop(scenario).wall_s)
            t0, c1 = time.perf_counter(), time.thread_time()
            run = run_engine(scenario, Path(tmp) / f"run{i}")
            recorded.append(time.perf_counter() - t0)
            plain_cpu.append(c1 - c0)
            recorded_cpu.append(time.thread_time() - c1)
            size = sum(p.stat().st_size for p in (Path(tmp) / f"run{i}").glob("*.mcap"))
            messages = run.message_count
    steps = round(scenario.duration_s * scenario.sim_rate_hz)
    return {"steps": steps, "unrecorded_s": min(plain), "recorded_s": min(recorded),
            "ratio": min(recorded) / min(plain), "bag_mb": size / 1e6, "messages": messages,
            "unrecorded_cpu_s": min(plain_cpu), "recorded_cpu_s": min(recorded_cpu)}


@cli_boundary("engine_record")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.engine_record",
                                     description="What recording its bag costs the engine: steps/s unrecorded "
                                                 "and recorded, their ratio (target <= 3x), the bag's size.")
    parser.add_argument("--scenario", default="sighting_land_vehicle")
    parser.add_argument("--variant", default="ekf_on", help="variant of a scenario with variants (default ekf_on)")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds (default 10)")
    parser.add_argument("--pairs", type=int, default=3, help="alternating unrecorded/recorded pairs (default 3)")
    args = parser.parse_args(argv)
    finite(args.duration, "--duration", 0.0, strict=True)
    scenario = load(args.scenario)
    if scenario.variants:
        scenario = variant(scenario, args.variant)
    scenario = dataclasses.replace(scenario, duration_s=args.duration)
    r = measure(scenario, max(1, args.pairs))
    verdict = "meets" if r["ratio"] <= TARGET_RATIO else "MISSES"
    print(f"{scenario.name}, {args.duration:g} s simulated ({r['steps']:,} steps), best of {max(1, args.pairs)}:")
    print(f"  unrecorded  {r['unrecorded_s']:.2f} s  ({r['steps'] / r['unrecorded_s']:,.0f} steps/s)")
    print(f"  recorded    {r['recorded_s']:.2f} s  ({r['steps'] / r['recorded_s']:,.0f} steps/s), "
          f"{r['messages']:,} messages, {r['bag_mb']:.1f} MB bag")
    print(f"  recording costs {r['ratio']:.2f}x  (target <= {TARGET_RATIO:g}x: {verdict})")
    print(f"  stepping thread's CPU: {r['unrecorded_cpu_s']:.3f} s unrecorded, {r['recorded_cpu_s']:.3f} s recorded, "
          f"{r['recorded_cpu_s'] / r['unrecorded_cpu_s']:.2f}x (the wall ratio with a core free for the bag's thread)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
