"""Speed and memory of ``gimbal-allan`` on long bags (a 2 h bag at 100 Hz, 720k
messages, in under 60 s; memory growing with the message count by no more than the sample
arrays).

Writes bags of a numpy-made static gyro (white noise and a rate random walk) with our bag
writer as the recorder writes them (a chunk every 0.5 s of stamps), then times
``gimbal-allan`` on each in a subprocess under ``/usr/bin/time -v`` (wall time, peak RSS).
Two lengths give the memory per message: the slope of peak RSS against the message count,
next to the 32 bytes a message that the stamp and three values take as float64/int64 (the
analysis then holds a few more arrays of the samples: the per-axis copies and the phase).

``python -m gimbal_sim.tools.allan_speed [--hours 0.5 2] [--rate-hz 100] [--keep DIR]``
"""
from __future__ import annotations

import argparse
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gimbal_kinematics.ros import messages as m

from ..bag.writer import BagWriter

TARGET_S = 60.0


def write_gyro_bag(path: Path, hours: float, rate_hz: float, seed: int = 0) -> int:
    """A static 3-axis gyro on ``/imu`` for ``hours`` at ``rate_hz``; returns the message count."""
    n = int(round(hours * 3600.0 * rate_hz))
    dt = 1.0 / rate_hz
    rng = np.random.default_rng(seed)
    arw, rrw = 0.15 * math.pi / 180 / 60, 15.6 * math.pi / 180 / 3600 / 60  # rad/√s, rad/s/√s
    writer = BagWriter(path)
    writer.add_topic("/imu", "sensor_msgs/msg/Imu", [])
    walk = np.zeros(3)
    step = 100_000  # samples made per numpy call
    for start in range(0, n, step):
        k = min(step, n - start)
        rates = arw / math.sqrt(dt) * rng.standard_normal((k, 3))
        walks = walk + np.cumsum(rrw * math.sqrt(dt) * rng.standard_normal((k, 3)), axis=0)
        walk = walks[-1]
        for i, w in enumerate((rates + walks).tolist()):
            t_ns = 1_700_000_000_000_000_000 + int(round((start + i) * dt * 1e9))
            writer.write("/imu", m.imu_cdr(t_ns, "imu", angular_velocity=w), t_ns)
    writer.close()
    return n


def time_gimbal_allan(bag: Path, out: Path) -> tuple[float, float, float]:
    """(wall s, CPU s (user + system), peak RSS MB) of ``gimbal-allan`` on ``bag``, from
    ``/usr/bin/time -v``. On a shared machine the CPU time is the stable figure."""
    exe = Path(sys.executable).with_name("gimbal-allan")
    cmd = ["/usr/bin/time", "-v", str(exe), str(bag), "--topic", "/imu", "--out", str(out), "--no-progress"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"gimbal-allan failed ({proc.returncode}): {proc.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", proc.stderr)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    seconds = float(wall.group(1) or 0) * 3600 + float(wall.group(2)) * 60 + float(wall.group(3))
    cpu = sum(float(re.search(rf"{kind} time \(seconds\): ([\d.]+)", proc.stderr).group(1))
              for kind in ("User", "System"))
    return seconds, cpu, int(rss.group(1)) / 1024.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.allan_speed",
                                     description="Time gimbal-allan (wall time, peak RSS) on long bags.")
    parser.add_argument("--hours", nargs="+", type=float, default=[0.5, 2.0], help="bag lengths [h]")
    parser.add_argument("--rate-hz", type=float, default=100.0)
    parser.add_argument("--keep", type=Path, help="keep the bags and outputs in this (new) directory")
    args = parser.parse_args(argv)
    if not args.rate_hz > 0 or min(args.hours) <= 0:
        print("allan_speed: --hours and --rate-hz must be > 0", file=sys.stderr)
        return 2
    if not Path("/usr/bin/time").is_file():
        print("allan_speed: needs /usr/bin/time (GNU time)", file=sys.stderr)
        return 2
    if args.keep is not None and args.keep.exists():
        print(f"allan_speed: --keep {args.keep} already exists; not overwriting it", file=sys.stderr)
        return 2
    root = Path(tempfile.mkdtemp(prefix="allan_speed_")) if args.keep is None else args.keep
    rows = []
    try:
        for hours in sorted(args.hours):
            t0 = time.perf_counter()
            n = write_gyro_bag(root / f"bag_{hours:g}h", hours, args.rate_hz)
            made = time.perf_counter() - t0
            wall, cpu, rss = time_gimbal_allan(root / f"bag_{hours:g}h", root / f"out_{hours:g}h")
            rows.append((hours, n, wall, rss))
            print(f"{hours:g} h at {args.rate_hz:g} Hz: {n:,} messages (bag written in {made:.0f} s): gimbal-allan "
                  f"{wall:.1f} s wall, {cpu:.1f} s CPU, peak RSS {rss:.0f} MB", flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)
    longest = rows[-1]
    if abs(longest[0] - 2.0) < 1e-9 and args.rate_hz == 100.0:
        print(f"target: 2 h at 100 Hz in < {TARGET_S:g} s: {longest[2]:.1f} s "
              f"{'met' if longest[2] < TARGET_S else 'NOT MET'}")
    if len(rows) > 1:
        (_, n0, _, r0), (_, n1, _, r1) = rows[0], rows[-1]
        per_msg = (r1 - r0) * 1024 * 1024 / (n1 - n0)
        print(f"memory: peak RSS grows {per_msg:.0f} bytes per message ({n0:,} -> {n1:,} messages); the samples "
              f"take 32 bytes a message (int64 stamp + 3 float64)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
