"""How often ``gimbal-allan``'s model selection invents a term, and how well it keeps the true ones.

Records of a gyro triad at rest made with numpy alone (no simulator code): white rate noise
(ARW), a rate random walk (RRW) and, in the ``gm`` mix, a first-order Gauss-Markov bias, at
10 Hz; each axis of each seed is characterised by :func:`gimbal_sim.allan.analyze.analyze`.
Counted per axis: a term detected that the record does not hold (false detection), a term
held and missed, and the fitted RRW (and Gauss-Markov σ, T) against the truth.

``python -m gimbal_sim.tools.allan_selection [--mixes white_rrw gm] [--records 50] [--hours 6]
[--jobs 1] [--json FILE]`` prints one table; the figures are in docs/results/allan.md.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from gimbal_kinematics.maths.units import DEG

from ..allan.analyze import analyze
from ..allan.stream import ImuField

RATE_HZ = 10.0
#: mix -> ARW [deg/√h], RRW [deg/h/√h], Gauss-Markov σ [deg/h], its T [s]
MIXES = {"white_rrw": (0.2, 20.0, 0.0, 0.0), "gm": (0.2, 20.0, 5.0, 10.0)}
SPURIOUS = ("gauss_markov", "ramp", "quantization")
RRW_BOUND = 0.30


def record(mix: str, seed: int, hours: float) -> ImuField:
    """Three independent axes of the mix (module docstring), epoch stamps at 10 Hz."""
    arw, rrw, gm, tc = MIXES[mix]
    rng = np.random.default_rng(seed)
    n = int(round(hours * 3600.0 * RATE_HZ))
    dt = 1.0 / RATE_HZ
    N, K, sigma = arw * DEG / 60.0, rrw * DEG / 3600.0 / 60.0, gm * DEG / 3600.0
    y = N / math.sqrt(dt) * rng.standard_normal((n, 3)) + np.cumsum(K * math.sqrt(dt) * rng.standard_normal((n, 3)),
                                                                  axis=0)
    if sigma:
        phi = math.exp(-dt / tc)
        e = sigma * math.sqrt(1.0 - phi * phi) * rng.standard_normal((n, 3))
        e[0] = sigma * rng.standard_normal(3)  # stationary from the first sample
        y += lfilter([1.0], [1.0, -phi], e, axis=0)
    stamps = 1_735_689_600_000_000_000 + np.arange(n, dtype=np.int64) * int(round(1e9 * dt))
    return ImuField(topic="/imu", field="angular_velocity", msgtype="sensor_msgs/msg/Imu", stamps_ns=stamps,
                    values=y, absent=0, unmeasured=np.zeros(3, dtype=int), stamp_source="header")


def one_record(mix: str, seed: int, hours: float) -> list[dict]:
    """Per axis: the detected terms and fitted / true RRW, σ and T."""
    arw, rrw, gm, tc = MIXES[mix]
    result = analyze(record(mix, seed, hours))
    rows = []
    for axis, res in result.axes.items():
        terms = res.fit.terms
        rows.append({"mix": mix, "seed": seed, "axis": axis,
                     "detected": [t for t, e in terms.items() if e.detected],
                     "rrw_ratio": terms["rrw"].value * 3600.0 * 60.0 / DEG / rrw if terms["rrw"].detected else None,
                     "gm_ratio": (terms["gauss_markov"].value * 3600.0 / DEG / gm
                                  if gm and terms["gauss_markov"].detected else None),
                     "tc_ratio": res.fit.tc / tc if gm and res.fit.tc else None})
    return rows


def summarise(rows: list[dict]) -> dict:
    """Per mix: false-detection rate of each spurious term and of any, RRW within 30 %, and for
    the Gauss-Markov mix its detection rate and σ, T within 30 % / x2."""
    out = {}
    for mix in dict.fromkeys(r["mix"] for r in rows):
        mine = [r for r in rows if r["mix"] == mix]
        n = len(mine)
        held = MIXES[mix][2] > 0.0
        s = {"axes": n, "rrw_within_30": sum(r["rrw_ratio"] is not None and abs(r["rrw_ratio"] - 1.0) <= RRW_BOUND
                                             for r in mine) / n}
        spurious = [t for t in SPURIOUS if not (held and t == "gauss_markov")]
        for t in spurious:
            s[f"false_{t}"] = sum(t in r["detected"] for r in mine) / n
        s["false_any"] = sum(any(t in r["detected"] for t in spurious) for r in mine) / n
        if held:
            s["gm_detected"] = sum("gauss_markov" in r["detected"] for r in mine) / n
            s["gm_within_30"] = sum(r["gm_ratio"] is not None and abs(r["gm_ratio"] - 1.0) <= RRW_BOUND
                                    for r in mine) / n
            s["tc_within_x2"] = sum(r["tc_ratio"] is not None and 0.5 <= r["tc_ratio"] <= 2.0 for r in mine) / n
        ratios = np.array([r["rrw_ratio"] for r in mine if r["rrw_ratio"] is not None])
        s["rrw_ratio_mean"] = float(ratios.mean()) if ratios.size else None
        s["rrw_ratio_worst"] = float(np.max(np.abs(ratios - 1.0))) if ratios.size else None
        out[mix] = s
    return out


def table(summary: dict, records: int, hours: float) -> str:
    lines = [f"gimbal-allan model selection: {records} records x 3 axes, {hours:g} h at {RATE_HZ:g} Hz "
             f"(mixes: ARW deg/rt h, RRW deg/h/rt h, GM deg/h, T s = {MIXES})",
             "| mix | axes | false GM | false ramp | false quant. | any false | RRW within 30 % | RRW mean ratio | "
             "worst RRW error | GM detected | GM σ within 30 % | T within x2 |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]

    def pct(v):
        return "—" if v is None else f"{100.0 * v:.1f} %"
    for mix, s in summary.items():
        lines.append(f"| {mix} | {s['axes']} | {pct(s.get('false_gauss_markov'))} | {pct(s['false_ramp'])} | "
                     f"{pct(s['false_quantization'])} | {pct(s['false_any'])} | {pct(s['rrw_within_30'])} | "
                     f"{s['rrw_ratio_mean']:.3f} | {pct(s['rrw_ratio_worst'])} | {pct(s.get('gm_detected'))} | "
                     f"{pct(s.get('gm_within_30'))} | {pct(s.get('tc_within_x2'))} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.allan_selection",
                                     description="False-detection rate of gimbal-allan's model selection over "
                                                 "seeded numpy records of a gyro at rest.")
    parser.add_argument("--mixes", nargs="+", default=list(MIXES), choices=list(MIXES))
    parser.add_argument("--records", type=int, default=50, help="seeds 0..records-1 per mix")
    parser.add_argument("--hours", type=float, default=6.0, help="record length [h]")
    parser.add_argument("--jobs", type=int, default=1, help="processes")
    parser.add_argument("--json", type=Path, help="write every axis and the summary to this file")
    args = parser.parse_args(argv)
    for name, value, ok in (("--records", args.records, args.records >= 1), ("--jobs", args.jobs, args.jobs >= 1),
                            ("--hours", args.hours, math.isfinite(args.hours) and args.hours > 0.0)):
        if not ok:
            print(f"allan_selection: {name} must be positive, got {value}", file=sys.stderr)
            return 2
    if args.json is not None and args.json.exists():
        print(f"allan_selection: --json {args.json} already exists; not overwriting it", file=sys.stderr)
        return 2
    jobs = [(mix, seed, args.hours) for mix in args.mixes for seed in range(args.records)]
    t0 = time.perf_counter()
    rows: list[dict] = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for done in pool.map(one_record, *zip(*jobs)):
            rows.extend(done)
            print(json.dumps(done), file=sys.stderr, flush=True)  # one line per record: a partial study survives
    summary = summarise(rows)
    print(table(summary, args.records, args.hours))
    print(f"({len(jobs)} records in {time.perf_counter() - t0:.0f} s)")
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "summary": summary}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
