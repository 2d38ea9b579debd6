"""``gimbal-bench``: benchmarks that print their figures (speed targets live here, not in tests).

``gimbal-bench [run]`` (default): one scenario (default ``sighting_land_vehicle``, variant
``ekf_on``) measured three ways, every speed in lockstep steps per second:

* (a) the limit: the scenario's cores stepped in one Python loop, no ROS
  (:mod:`..core.core_loop`, in a subprocess so its memory is its own);
* (b) container mode: every node and the recorder in one process;
* (c) processes mode: one OS process per node.

For each: wall time of the stepping (first to last step) and real-time factor, steps/s
and the ratio to (a), step latency p50/p99 (wall time between consecutive steps as the
run's monitor sees ``/clock``), CPU seconds per process while stepping (start-up apart),
peak RSS, messages recorded and lost (gaps in each topic's stamps), messages delivered to
subscribers per step (:mod:`.deliveries`). Then the speed of
replaying the recorded sensor topics into the gyro-bias EKF, checks that (b) and (c)
recorded the same data and that (a) computed the same torque commands, and, with
``--memory``, resident memory over a run ``--memory-factor`` times longer.

``record``: the recorder's throughput, CPU share and bag size on a scenario run (processes
mode), with zstd-compressed chunks and without.
``compare A B``: do two bags hold the same data (:mod:`..bag.compare`)?
``live``: steps/s without and with ``--live`` and one client over alternating pairs of runs,
their median, same data (:mod:`.live_speed`).
``engine``: the no-ROS engine at the papers' 1 kHz loops, each figure against its target,
side by side with another checkout's Python (``--baseline``) (:mod:`.engine_speed`).
"""
from __future__ import annotations

import argparse
import atexit
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from statistics import median
from typing import Any

from gimbal_kinematics.cli.boundary import cli_boundary, finite, writable_dir
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError, read_stamp

from ..bag.compare import compare_bags
from ..bag.reader import BagError, read_messages
from ..core.core_loop import NoCoreError, node_values, run_core_loop
from ..bag.ekf_replay import EKF_INPUTS, replay_bag
from ..experiments.flexure_methods import QS_MODELS, method_table, run_method_study
from ..graph.orchestrator import run
from ..graph.registry import NODE_TYPES
from ..graph.scenario import Scenario, ScenarioError, load, variant
from . import engine_speed
from .live_speed import live_report, measure_live
from .deliveries import DELIVERY_STEPS, deliveries_row
from .replay_speed import measure
from .record_speed import bench_record, note as _note

HEADLINE = "sighting_land_vehicle"
EKF_EXECUTABLE = "gyro_bias_ekf"

#: The speed targets (steps/s, ratios, ms, x real time, fraction of a core, fraction).
TARGETS = {"core_steps_s": 20_000.0, "container_steps_s": 5_000.0, "container_ratio": 3.0,
           "processes_steps_s": 2_000.0, "processes_ratio": 8.0, "p99_ms": 1.0, "replay_x": 50.0, "play_x": 8.0,
           "recorder_core": 0.15, "rss_growth": 0.10}


def _percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(round(q * (len(s) - 1))))]


@dataclass
class ModeResult:
    """One way of running the scenario (module docstring)."""

    name: str
    steps: int
    wall_s: float                      # stepping: first to last step
    sim_s: float
    latency_s: list[float]             # per-step wall intervals
    cpu_s: dict[str, float]            # process -> CPU seconds while stepping
    startup_cpu_s: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: dict[str, float] = field(default_factory=dict)
    total_wall_s: float = 0.0          # including start-up and shutdown
    recorded: int | None = None
    lost: int | None = None
    bag: Path | None = None
    rss_samples: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    @property
    def steps_per_s(self) -> float:
        return self.steps / self.wall_s if self.wall_s > 0 else float("inf")

    @property
    def rtf(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else float("inf")


# ------------------------------------------------------------------------------ (a)
def measure_core(scenario: Scenario) -> ModeResult:
    """(a): :mod:`..core.core_loop` in a subprocess (its CPU and peak RSS are then its own)."""
    cmd = [sys.executable, "-m", "gimbal_sim.core.core_loop", str(_scenario_file(scenario)), "--json"]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"core loop failed: {proc.stderr.strip()[-2000:]}")
    r = json.loads(proc.stdout)
    return ModeResult("(a) cores", r["steps"], r["wall_s"], r["sim_s"], r["step_latency_s"],
                      {"core loop": r["cpu_s"]}, peak_rss_mb={"core loop": r["peak_rss_mb"]},
                      total_wall_s=time.monotonic() - t0)


_SCENARIO_DIR: Path | None = None


def _scenario_file(scenario: Scenario) -> Path:
    """The scenario as a YAML file (what core_loop's command line takes)."""
    global _SCENARIO_DIR
    if _SCENARIO_DIR is None:
        _SCENARIO_DIR = Path(tempfile.mkdtemp(prefix="gimbal-bench-scenario-"))
        atexit.register(shutil.rmtree, _SCENARIO_DIR, True)
    path = _SCENARIO_DIR / f"{scenario.name}.yaml"
    path.write_text(scenario.to_yaml())
    return path


# ------------------------------------------------------------------------------ (b), (c)
def count_lost(bag: Path, sim_rate_hz: float, end_ns: int) -> tuple[int, int, dict[str, int]]:
    """(messages recorded, messages missing, per-topic missing) from each topic's stamps:
    a topic published every N steps must have one message per N steps from its first
    stamp to the end of the run. Topics with fewer than three messages are not judged."""
    messages, contents = read_messages(bag)
    stamps: dict[str, list[int]] = {}
    for msg in messages:
        try:
            stamps.setdefault(msg.topic, []).append(read_stamp(msg.data))
        except CdrError:
            stamps.setdefault(msg.topic, []).append(msg.log_time_ns)
    step_ns = 1e9 / sim_rate_hz
    missing: dict[str, int] = {}
    for topic, st in stamps.items():
        if len(st) < 3:
            continue
        st.sort()
        diffs = [b - a for a, b in zip(st, st[1:])]
        interval = median(diffs)
        if interval <= 0:
            continue
        gaps = sum(max(0, round(d / interval) - 1) for d in diffs)
        tail = max(0, int((end_ns - st[-1] + 0.5 * step_ns) // interval))
        missing[topic] = gaps + tail
    return len(messages), sum(missing.values()), missing


def measure_graph(scenario: Scenario, mode: str, out: Path) -> ModeResult:
    """(b) or (c): the orchestrator's run, with its telemetry."""
    t0 = time.monotonic()
    r = run(scenario, out, mode, progress=False)
    if r.interrupted:  # the graph stopped in order; the benchmark stops with it
        raise KeyboardInterrupt(f"stopped the benchmark in its {mode} run; only --keep keeps its runs")
    total = time.monotonic() - t0
    step_ns = 1e9 / scenario.sim_rate_hz
    stamps, walls = r.clock_stamp, r.clock_wall
    latency = [walls[i + 1] - walls[i] for i in range(len(walls) - 1)
               if abs(stamps[i + 1] - stamps[i] - step_ns) < 0.5 * step_ns]
    steps = round((stamps[-1] - stamps[0]) / step_ns) if len(stamps) > 1 else 0
    procs = dict(r.processes)
    if mode == "processes":
        procs["gimbal-run (monitor)"] = r.orchestrator
        start = {("gimbal-run (monitor)" if k == "orchestrator" else k): v for k, v in r.cpu_at_start.items()}
    else:
        start = {"container": r.cpu_at_start.get("container", 0.0)}
    cpu = {name: st.cpu_s - start.get(name, 0.0) for name, st in procs.items()}
    recorded, lost, _ = count_lost(out, scenario.sim_rate_hz, int(round(scenario.duration_s * 1e9)))
    label = "(b) container" if mode == "container" else "(c) processes"
    return ModeResult(label, steps, walls[-1] - walls[0] if len(walls) > 1 else 0.0, steps / scenario.sim_rate_hz,
                      latency, cpu, start, {n: st.peak_rss_mb for n, st in procs.items()}, total, recorded, lost, out,
                      r.rss_samples)


# ------------------------------------------------------------------------------ replay
def replay_ekf_core(bag: Path, scenario: Scenario) -> tuple[float, float, float, int] | None:
    """Replay the recorded sensor topics into the GyroBiasEkf core: (simulated s, wall s and
    CPU s including decoding, updates), or None when the bag lacks them."""
    values = next((v for exe, v in node_values(scenario).values() if exe == EKF_EXECUTABLE), None)
    if values is None:  # a scenario without the EKF: replay into one with the node's defaults
        values = {p.name: p.default for p in NODE_TYPES[EKF_EXECUTABLE].params}
    return replay_bag(bag, values)


def replay_ekf_node(bag: Path) -> tuple[str, Any]:
    """``gimbal-bag play --rate 0`` of the recorded sensor topics into a free-timing
    ``gyro_bias_ekf`` node (:mod:`.replay_speed`): (the line to print, the measurement or None)."""
    try:
        result = measure(bag)
    except Exception as exc:  # noqa: BLE001 - a benchmark prints what failed and goes on
        return f"not measured: {type(exc).__name__}: {exc}", None
    return result.summary(), result


# ------------------------------------------------------------------------------ report
def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def report(scenario: Scenario, results: list[ModeResult], extra: list[tuple[str, str]], verdicts: list[tuple[str, str, bool | None]]) -> str:
    core = next((r for r in results if r.name.startswith("(a)")), None)
    width = 24
    lines = [f"gimbal-bench: {scenario.name}, {scenario.duration_s:g} s simulated at {scenario.sim_rate_hz:g} Hz = "
             f"{round(scenario.duration_s * scenario.sim_rate_hz):,} lockstep steps, seed {scenario.seed}",
             f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the end "
             "(other work on the machine slows every figure below)", ""]
    cols = [r.name for r in results]
    row = lambda label, vals: f"{label:<{width}}" + "".join(f"{v:>18}" for v in vals)  # noqa: E731
    lines.append(row("", cols))
    lines.append(row("wall time (stepping) [s]", [_fmt(r.wall_s, ".2f") for r in results]))
    lines.append(row("wall time (total) [s]", [_fmt(r.total_wall_s, ".2f") for r in results]))
    lines.append(row("real-time factor", [_fmt(r.rtf, ".2f") for r in results]))
    lines.append(row("steps/s", [_fmt(r.steps_per_s, ",.0f") for r in results]))
    lines.append(row("ratio to (a)", [_fmt(core.steps_per_s / r.steps_per_s if core else None, ".2f") + "x"
                                      for r in results]))
    lines.append(row("step latency p50 [ms]", [_fmt(1e3 * _percentile(r.latency_s, 0.5), ".3f") for r in results]))
    lines.append(row("step latency p99 [ms]", [_fmt(1e3 * _percentile(r.latency_s, 0.99), ".3f") for r in results]))
    lines.append(row("CPU, all processes [s]", [_fmt(sum(r.cpu_s.values()), ".2f") for r in results]))
    lines.append(row("CPU per step [us]", [_fmt(1e6 * sum(r.cpu_s.values()) / max(1, r.steps), ",.0f")
                                           for r in results]))
    lines.append(row("steps per CPU second", [_fmt(r.steps / max(1e-9, sum(r.cpu_s.values())), ",.0f")
                                              for r in results]))
    lines.append(row("peak RSS, largest [MiB]", [_fmt(max(r.peak_rss_mb.values(), default=0.0), ".0f")
                                                 for r in results]))
    lines.append(row("messages recorded", [_fmt(r.recorded, ",d") if r.recorded is not None else "-"
                                           for r in results]))
    lines.append(row("messages lost", [_fmt(r.lost, "d") if r.lost is not None else "-" for r in results]))
    lines += ["", "CPU seconds while stepping (start-up apart), share of one core at real time, peak RSS:"]
    for r in results:
        for name, cpu in r.cpu_s.items():
            share = cpu / r.sim_s if r.sim_s else float("nan")
            lines.append(f"  {r.name:<14} {name:<22} {cpu:8.2f} s  {100 * share:6.1f} % of a core  "
                         f"{1e6 * cpu / max(1, r.steps):8.1f} us/step  start-up {r.startup_cpu_s.get(name, 0.0):5.2f} s"
                         f"  peak RSS {r.peak_rss_mb.get(name, 0.0):5.0f} MiB")
    if extra:
        lines.append("")
        w = max(len(k) for k, _ in extra)
        lines += [f"{k:<{w}}  {v}" for k, v in extra]
    if verdicts:
        lines += ["", "targets:"]
        w = max(len(k) for k, _, _ in verdicts)
        for name, value, ok in verdicts:
            mark = "met" if ok else ("NOT MET" if ok is not None else "not measured")
            lines.append(f"  {name:<{w}}  {value:<34} {mark}")
    return "\n".join(lines)


def _verdicts(results: dict[str, ModeResult], replay_x: float | None, rss_growth: float | None,
              play: Any = None) -> list:
    t = TARGETS
    a, b, c = (r if r is not None and r.steps > 0 else None
               for r in (results.get("core"), results.get("container"), results.get("processes")))
    out = []

    def ratio(r):
        return a.steps_per_s / r.steps_per_s if a and r else None

    if a:
        out.append(("(a) cores >= 20,000 steps/s", f"{a.steps_per_s:,.0f} steps/s", a.steps_per_s >= t["core_steps_s"]))
    if b:
        out.append(("(b) container >= 5,000 steps/s", f"{b.steps_per_s:,.0f} steps/s",
                    b.steps_per_s >= t["container_steps_s"]))
        if a:
            out.append(("(b) within 3x of (a)", f"{ratio(b):.1f}x", ratio(b) <= t["container_ratio"]))
    if c:
        out.append(("(c) processes >= 2,000 steps/s", f"{c.steps_per_s:,.0f} steps/s",
                    c.steps_per_s >= t["processes_steps_s"]))
        if a:
            out.append(("(c) within 8x of (a)", f"{ratio(c):.1f}x", ratio(c) <= t["processes_ratio"]))
        p99 = 1e3 * _percentile(c.latency_s, 0.99)
        out.append(("(c) step latency p99 < 1 ms", f"{p99:.3f} ms", p99 < t["p99_ms"]))
        rec = c.cpu_s.get("bag_recorder")
        if rec is not None:
            share = rec / c.sim_s
            out.append(("recorder <= 15 % of a core", f"{100 * share:.1f} % at real time", share <= t["recorder_core"]))
    lost = [r.lost for r in (b, c) if r and r.lost is not None]
    if lost:
        out.append(("zero messages lost", f"{sum(lost)} lost", sum(lost) == 0))
    out.append(("replay into the EKF >= 50x real time", "-" if replay_x is None else f"{replay_x:,.1f}x (core)",
                None if replay_x is None else replay_x >= t["replay_x"]))
    out.append(("play into the EKF node >= 8x, exact", "-" if play is None else
                f"{play.speed_x:,.1f}x ({'exact' if play.exact else 'NOT exact'})",
                None if play is None else play.speed_x >= t["play_x"] and play.exact))
    out.append(("RSS flat over a longer run (<= 10 %)", "-" if rss_growth is None else f"{100 * rss_growth:+.1f} %",
                None if rss_growth is None else rss_growth <= t["rss_growth"]))
    return out


def rss_growth(samples: dict[str, list[tuple[float, float]]], sim_s: float) -> dict[str, tuple[float, float, float]]:
    """process -> (RSS after 10 % of the run, RSS at the end [MiB], growth fraction)."""
    out = {}
    for name, s in samples.items():
        s = [x for x in s if x[1] > 0.0]
        later = [x for x in s if x[0] >= 0.1 * sim_s]
        if len(later) < 2:
            continue
        base, end = later[0][1], later[-1][1]
        out[name] = (base, end, (end - base) / base)
    return out


def bench_run(args: argparse.Namespace) -> int:
    scenario = load(args.scenario or HEADLINE)
    if scenario.variants:
        # one run per mode: the named variant, or the last (the headline's ekf_on: the
        # controller waits for the EKF at every INS step, the most synchronised graph)
        scenario = variant(scenario, args.variant or list(scenario.variants)[-1])
    elif args.variant:
        raise ScenarioError(f"--variant {args.variant}: scenario {scenario.name} has no variants")
    if args.duration is not None:
        scenario = dataclasses.replace(scenario, duration_s=args.duration)
    if args.seed is not None:
        scenario = dataclasses.replace(scenario, seed=args.seed)
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    unknown = set(modes) - {"core", "container", "processes"}
    if unknown:
        raise ScenarioError(f"--modes: unknown {sorted(unknown)} (core, container, processes)")
    keep = Path(args.keep) if args.keep else None  # checked by _check_numbers, before anything runs
    tmp = tempfile.TemporaryDirectory(prefix="gimbal-bench-")
    root = keep or Path(tmp.name)
    results: dict[str, ModeResult] = {}
    extra: list[tuple[str, str]] = []
    try:
        for mode in modes:
            _note(f"{mode}: {scenario.name}, {scenario.duration_s:g} s simulated ...")
            if mode == "core":
                try:
                    results[mode] = measure_core(scenario)
                except (NoCoreError, RuntimeError) as exc:
                    extra.append(("(a) cores", f"not measured: {exc}"))
            else:
                results[mode] = measure_graph(scenario, mode, root / mode)
            if mode in results:
                _note(f"{mode}: {results[mode].steps_per_s:,.0f} steps/s")
        bags = [results[m].bag for m in ("processes", "container") if m in results]
        for mode in ("container", "processes"):
            r = results.get(mode)
            if r is not None and r.recorded is not None and r.steps:
                extra.append((f"{r.name} messages recorded per step", f"{r.recorded / r.steps:.2f} (the recorded "
                              "topics only; every publication to every subscriber is not counted)"))
        if bags:
            _note(f"deliveries: {DELIVERY_STEPS} steps recording every topic, subscriptions sampled ...")
            extra.append(deliveries_row(scenario, root / "deliveries"))
        if len(bags) == 2:
            diff = compare_bags(bags[1], bags[0])
            extra.append(("(b) and (c) recorded data", "identical (every message, stamp and field)" if diff.identical
                          else "DIFFERENT: " + "; ".join(line for line in diff.lines() if "identical" not in line)))
        if "core" in results and bags:
            extra.append(("(a) against the bag", _check_commands(scenario, bags[0])))
        replay_x = play = None
        if bags:
            _note("replaying the recorded sensor topics into the gyro-bias EKF ...")
            rep = replay_ekf_core(bags[0], scenario)
            if rep is None:
                extra.append(("replay into gyro_bias_ekf (core)", f"not measured: the bag lacks {list(EKF_INPUTS)}"))
            else:
                sim, wall, cpu, updates = rep
                replay_x = sim / wall
                extra.append(("replay into gyro_bias_ekf (core)",
                              f"{replay_x:,.1f}x real time ({sim:g} s of sensor data decoded and filtered in "
                              f"{wall:.2f} s wall, {cpu:.2f} s CPU = {sim / cpu:,.1f}x per CPU second; "
                              f"{updates} updates)"))
            _note("gimbal-bag play --rate 0 of the sensor topics into a gyro_bias_ekf node ...")
            text, play = replay_ekf_node(bags[0])
            extra.append(("replay into gyro_bias_ekf (node)", text))
        growth = None
        if args.memory:
            long = dataclasses.replace(scenario, duration_s=scenario.duration_s * args.memory_factor)
            _note(f"memory: processes mode over {long.duration_s:g} s simulated ...")
            mem = measure_graph(long, "processes", root / "memory")
            per = rss_growth(mem.rss_samples, mem.sim_s)
            growth = max((g for _, _, g in per.values()), default=None)
            extra.append((f"RSS over {long.duration_s:g} s ({args.memory_factor:g}x)",
                          ", ".join(f"{n} {b:.0f} -> {e:.0f} MiB ({100 * g:+.1f} %)" for n, (b, e, g) in per.items())))
        print(report(scenario, list(results.values()), extra, _verdicts(results, replay_x, growth, play)))
    finally:
        tmp.cleanup()
    return 0


def _check_commands(scenario: Scenario, bag: Path) -> str:
    """Does the core loop compute the torque commands the graph recorded, bit for bit?"""
    recorded = [m.joint_state_from_cdr(msg.data).effort for msg in read_messages(bag, {"/gimbal/torque_cmd"})[0]]
    if not recorded:
        return "no /gimbal/torque_cmd in the bag (open loop): nothing to check"
    ours = run_core_loop(scenario, keep_commands=True).commands
    same = sum(tuple(a) == tuple(b) for a, b in zip(recorded, ours))
    return (f"same torque commands as the graph at all {same} steps" if same == len(recorded) == len(ours) else
            f"DIFFERENT torque commands: {same} of {len(recorded)} recorded steps equal ({len(ours)} computed)")


def bench_compare(args: argparse.Namespace) -> int:
    try:
        diff = compare_bags(Path(args.a), Path(args.b), rel_tol=args.rel_tol)
    except BagError as exc:
        print(f"gimbal-bench compare: {exc}", file=sys.stderr)
        return 2
    for line in diff.warnings:
        print(line, file=sys.stderr)
    print("\n".join(diff.lines()))
    unreadable = sorted(t.topic for t in diff.topics.values() if t.unreadable)
    ok = diff.identical or (args.rel_tol > 0 and diff.within_tolerance)
    if unreadable:
        print(f"NOT COMPARABLE: a bag is damaged: {len(unreadable)} topic(s) cannot be read on a side "
              f"({', '.join(unreadable)}); `gimbal-bag info` on each bag says where")
        return 2   # a damaged bag is bad input, as for every command
    else:
        print("same data" if diff.identical else (f"within tolerance (--rel-tol {args.rel_tol:g})" if ok
                                                  else "DIFFERENT data"))
    return 0 if ok else 1


def bench_flexure(args: argparse.Namespace) -> int:
    """Paper 5's two attitude-matching methods, original (eq. 1) and simplified, fed the same
    LGU pairs by the sensor cores without ROS: accuracy and cost per pair in one table
    (:mod:`..experiments.flexure_methods`)."""
    if not args.duration > 600.0 or args.duration == float("inf"):
        print(f"gimbal-bench flexure: --duration must be finite and > 600 s (the convergence time), "
              f"got {args.duration}", file=sys.stderr)
        return 2
    course = "the turning manoeuvre (ship_flexure_turn)" if args.turn else "ship_flexure"
    print(f"flexure attitude matching, original vs simplified: {args.duration:g} s of {course} per seed, "
          f"LGU pairs at 10 Hz, seeds {' '.join(map(str, args.seeds))}, scored after 600 s:")
    print(method_table(run_method_study(args.duration, args.seeds, tuple(args.models), args.turn), args.turn))
    return 0


def bench_live(args: argparse.Namespace) -> int:
    if args.pairs < 1:
        print(f"gimbal-bench live: --pairs must be >= 1, got {args.pairs}", file=sys.stderr)
        return 2
    scenario = load(args.scenario or HEADLINE)
    if scenario.variants:
        scenario = variant(scenario, args.variant or list(scenario.variants)[-1])
    scenario = dataclasses.replace(scenario, duration_s=args.duration)
    with tempfile.TemporaryDirectory(prefix="gimbal-bench-live-") as work:
        r = measure_live(scenario, Path(work), args.port, args.mode, args.pairs)
    print(live_report(f"{scenario.name}, {args.duration:g} s, {args.mode} mode", r))
    return 0 if r["same_data"] and r["client_connected"] else 1


def bench_engine(args: argparse.Namespace) -> int:
    """``gimbal-bench engine``: :mod:`.engine_speed`'s figures against their targets."""
    if args.pairs < 1:
        print(f"gimbal-bench engine: --pairs must be >= 1, got {args.pairs}", file=sys.stderr)
        return 2
    if args.baseline is not None and not (os.path.isfile(args.baseline) and os.access(args.baseline, os.X_OK)):
        print(f"gimbal-bench engine: --baseline {args.baseline}: not an executable Python", file=sys.stderr)
        return 2
    factor = args.memory_factor if args.memory else None
    three_hours = getattr(args, "three_hours", False)
    try:
        if args.profile:
            for python in (sys.executable, args.baseline):
                if python is not None:
                    print(engine_speed.profile_report(python, args.duration))
            return 0
        result = engine_speed.measure(args.duration, args.pairs, args.baseline, factor, three_hours)
    except RuntimeError as exc:
        print(f"gimbal-bench engine: {exc}", file=sys.stderr)
        return 1
    print(engine_speed.report(result, args.duration, factor, three_hours))
    return 0


def _check_numbers(args: argparse.Namespace) -> None:
    """Durations and factors finite and positive, and --keep a folder that can be created,
    before anything runs."""
    for option in ("duration", "memory_factor"):
        if getattr(args, option, None) is not None:
            finite(getattr(args, option), f"--{option.replace('_', '-')}", 0.0, strict=True)
    if getattr(args, "rel_tol", None) is not None:
        finite(args.rel_tol, "--rel-tol", 0.0)
    if getattr(args, "keep", None):
        writable_dir(args.keep, "--keep")


@cli_boundary("gimbal-bench", interrupted="stopped the benchmark before its report; only --keep keeps its runs")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="gimbal-bench", description=__doc__.split("\n\n")[0].split(": ", 1)[1],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="With no command, `run` (see `gimbal-bench run --help`).")
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", help="(a) cores, (b) container, (c) processes on one scenario, EKF replay, memory")
    run.add_argument("--scenario", help=f"scenario to benchmark (default {HEADLINE})")
    run.add_argument("--variant", help="variant of a scenario with variants (default its last: ekf_on for the headline)")
    run.add_argument("--duration", type=float, help="simulated seconds (default: the scenario's)")
    run.add_argument("--seed", type=int, help="seed (default: the scenario's)")
    run.add_argument("--modes", default="core,container,processes",
                     help="comma-separated subset of core,container,processes (default all three)")
    run.add_argument("--memory", action="store_true", help="also check that RSS stays flat over a longer run")
    run.add_argument("--memory-factor", type=float, default=10.0,
                     help="how many times longer the memory run is (default 10)")
    run.add_argument("--keep", help="keep the runs' bags in this directory (must not exist)")
    run.set_defaults(func=bench_run)
    rec = sub.add_parser("record", help="recorder throughput and CPU share on a scenario run")
    rec.add_argument("--scenario", default="sim_open_loop", help="scenario to record (default sim_open_loop)")
    rec.add_argument("--duration", type=float, default=20.0, help="simulated seconds (default 20)")
    rec.add_argument("--compress", choices=("both", "on", "off"), default="both",
                     help="record with zstd chunks, without, or both one after the other (default both)")
    rec.set_defaults(func=bench_record)
    flex = sub.add_parser("flexure", help="paper 5 flexure attitude matching, original vs simplified: accuracy "
                                          "and CPU per LGU pair on the same runs (cores, no ROS)")
    flex.add_argument("--duration", type=float, default=7200.0, help="simulated seconds per seed (default 7200)")
    flex.add_argument("--seeds", "--seed", type=int, nargs="+", default=[0], help="seeds (default 0)")
    flex.add_argument("--models", nargs="+", choices=QS_MODELS, default=["random_walk_rate"],
                      help="quasi-static models, each by both methods (default random_walk_rate)")
    flex.add_argument("--turn", action="store_true", help="on the turning manoeuvre of ship_flexure_turn")
    flex.set_defaults(func=bench_flexure)
    cmp_ = sub.add_parser("compare", help="do two bags hold the same data? every file of each, every chunk "
                                          "CRC-checked; per topic: same, different (where first) or unreadable "
                                          "(exit 0 only when every topic is readable and the same, 1 otherwise)")
    cmp_.add_argument("a")
    cmp_.add_argument("b")
    cmp_.add_argument("--rel-tol", type=float, default=0.0,
                      help="accept float fields within this relative tolerance (default 0: to the bit)")
    cmp_.set_defaults(func=bench_compare)
    live = sub.add_parser("live", help="steps/s without and with --live and one client; same data")
    live.add_argument("--scenario", help=f"scenario (default {HEADLINE})")
    live.add_argument("--variant", help="variant (default its last)")
    live.add_argument("--duration", type=float, default=10.0, help="simulated seconds (default 10)")
    live.add_argument("--port", type=int, default=8765, help="live view port (default 8765)")
    live.add_argument("--pairs", type=int, default=3,
                      help="pairs of runs, without and with, the order alternating (default 3); "
                           "each pair is printed, and the median slowdown")
    live.add_argument("--mode", choices=("processes", "container"), default="processes",
                      help="how the nodes run (default processes: the client's work is not the run's)")
    live.set_defaults(func=bench_live)
    eng = sub.add_parser("engine", help="the no-ROS engine at 1 kHz (paper 3's platform with full motor dynamics, "
                                        "paper 1's sighting loop): steps/s, ratios to --baseline, 3-hour projection")
    eng.add_argument("--baseline", help="another checkout's Python (its .venv/bin/python) to run the same cases")
    eng.add_argument("--duration", type=float, default=20.0, help="simulated seconds per run (default 20)")
    eng.add_argument("--pairs", type=int, default=3, help="runs per side, alternating the order (default 3)")
    eng.add_argument("--memory", action="store_true", help="also the peak RSS of a --memory-factor longer run")
    eng.add_argument("--memory-factor", type=float, default=10.0, help="(default 10)")
    eng.add_argument("--profile", action="store_true", help="instead: each case once under cProfile, each side")
    eng.add_argument("--three-hours", action="store_true",
                     help="also one whole 3-hour navigation run at 1 kHz: its wall time and peak RSS")
    eng.set_defaults(func=bench_engine)
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in ("run", "record", "flexure", "compare", "live", "engine", "-h", "--help"):
        argv = ["run", *argv]
    args = parser.parse_args(argv)
    _check_numbers(args)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
