"""``gimbal-bench engine``: the no-ROS engine's speed at the papers' own 1 kHz loops, each
figure printed against its target, side by side with another checkout when ``--baseline``
names that checkout's Python (its venv's ``bin/python``).

Cases, each run in a subprocess (its memory its own) by this interpreter and by the
baseline's, alternating which goes first, the median of ``--pairs`` taken:

* ``rotational_ins_navigation`` at 1 kHz with the motors' full dynamics (RK4 over the
  armature, 4 substeps, instead of the quasi-static step the 5 Hz campaign uses): paper 3's
  platform, IMU, resolvers, servo and navigator. This checkout runs the scenario on the
  engine at its paper rate (:func:`paper_rate_navigation`, :data:`NAV_ENGINE_SCRIPT`); a
  checkout without that function runs the same simulated work through the navigation
  experiment's loop (:data:`NAV_SCRIPT`);
* the same run recorded to a bag on the engine (this checkout only): its speed against the
  unrecorded one (recording may cost at most a factor :data:`RECORD_COST_TARGET`);
* ``sighting_land_vehicle`` at 1 kHz (the core loop, :func:`..core.core_loop.run_core_loop`).

Each case's script first runs 10 ms (loading the compiled kernels from their cache), then
times its run. ``--profile`` runs each case once under cProfile instead, on each side, and
prints its functions by own time (:func:`profile_report`). Figures: steps/s (engine loop,
wall time), the ratio to the baseline, the wall time of one 3-hour run projected from the
steps/s, and the peak RSS of a run ``--memory-factor`` times longer against the short one
(flat: within 10 %); ``--three-hours`` runs one whole 3-hour run instead of projecting it and
takes the peak RSS from it. The 1-minute load average is printed before and after: the
wall-time ratios are only meaningful on a quiet machine; the ratio of steps per CPU second,
printed beside them, moves less with the load.
"""
from __future__ import annotations

import dataclasses
import functools
import json
import os
import subprocess
import sys
from statistics import median
from typing import Any

from ..graph.scenario import load, variant

#: One navigation run at 1 kHz, rotation on, seed 1, the motors' full dynamics: ``work()``.
NAV_SCRIPT = """
import json, resource, sys
from gimbal_sim.experiments import navigation as nav
duration, substeps = float(sys.argv[1]), int(sys.argv[2])
config = nav.VehicleConfig
def full_dynamics(**kw):
    return config(**{**kw, "platform_integrator": "rk4", "platform_substeps": substeps})
nav.VehicleConfig = full_dynamics
nav.run_navigation(0.01, 1, rotate=True, rate_hz=1000.0)  # warm-up: compiled kernels loaded
def work():
    m = nav.run_navigation(duration, 1, rotate=True, rate_hz=1000.0, record_every_s=10.0)
    return {"steps": round(duration * 1000.0), "wall_s": m["wall_s"], "cpu_s": m["cpu_s"]}
"""
#: One engine run of ``rotational_ins_navigation`` at its paper rate (:func:`paper_rate_navigation`): ``work()``.
NAV_ENGINE_SCRIPT = """
import json, resource, sys
from gimbal_sim.core.core_loop import run_core_loop
from gimbal_sim.tools.engine_speed import paper_rate_navigation
duration = float(sys.argv[1])
run_core_loop(paper_rate_navigation(0.01))  # warm-up: compiled kernels loaded
def work():
    r = run_core_loop(paper_rate_navigation(duration))
    return {"steps": r.steps, "wall_s": r.wall_s, "cpu_s": r.cpu_s}
"""
#: The same run recorded to a bag (``run_engine``: the bag closed included): ``work()``.
NAV_RECORD_SCRIPT = """
import json, resource, sys, tempfile, time
from pathlib import Path
from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.tools.engine_speed import paper_rate_navigation
duration = float(sys.argv[1])
tmp = tempfile.TemporaryDirectory()
run_engine(paper_rate_navigation(0.01), Path(tmp.name) / "warm")  # warm-up: compiled kernels loaded
def work():
    c0 = time.process_time()
    r = run_engine(paper_rate_navigation(duration), Path(tmp.name) / "run")
    size = sum(f.stat().st_size for f in (Path(tmp.name) / "run").iterdir())
    return {"steps": r.result.steps, "wall_s": r.wall_s, "cpu_s": time.process_time() - c0,
            "messages": r.message_count, "bag_mb": size / 1e6}
"""
#: One core-loop run of a scenario (``python -m gimbal_sim.core.core_loop``'s loop): ``work()``.
CORE_SCRIPT = """
import dataclasses, json, resource, sys
from gimbal_sim.core.core_loop import run_core_loop
from gimbal_sim.graph.scenario import load
scenario = load(sys.argv[1])
run_core_loop(dataclasses.replace(scenario, duration_s=0.01))  # warm-up: compiled kernels loaded
def work():
    r = run_core_loop(dataclasses.replace(scenario, duration_s=float(sys.argv[2])))
    return {"steps": r.steps, "wall_s": r.wall_s, "cpu_s": r.cpu_s}
"""
#: Either script's end: its figures as JSON.
TIMED = """
out = work()
out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
print(json.dumps(out))
"""
#: Or, profiled: each function's own and cumulative share of the work, the largest first.
PROFILED = """
import cProfile, pstats
profile = cProfile.Profile()
profile.runcall(work)
stats = pstats.Stats(profile).stats
total = max(v[3] for v in stats.values())
rows = sorted(((v[2] / total, v[3] / total, v[1], f"{f.rsplit('/', 1)[-1]}:{n}") for (f, l, n), v in stats.items()),
              reverse=True)
print(json.dumps({"profile": rows[:int(sys.argv[-1])]}))
"""
SUBSTEPS = 4
PAPER_RATE_VARIANT = "rotation_on_1khz"
THREE_HOURS_S = 3 * 3600.0
THREE_HOURS_STEPS = 3 * 3600 * 1000
#: case -> (label, ratio target)
TARGETS = {"rotational_ins_navigation": ("rotational_ins_navigation, 1 kHz, full motor dynamics", 20.0),
           "sighting_land_vehicle": ("sighting_land_vehicle, 1 kHz", 10.0)}
THREE_HOUR_TARGET_S = 180.0
RSS_GROWTH_TARGET = 0.10
RECORD_COST_TARGET = 3.0
NAV_RECORDED = "rotational_ins_navigation, recorded"


def paper_rate_navigation(duration_s: float, seed: int | None = None):
    """``rotational_ins_navigation`` at paper 3's own loop, its variant :data:`PAPER_RATE_VARIANT`:
    every node at 1 kHz, the motors' full dynamics (RK4, 4 substeps), the servo's loops at their
    default bandwidths (placed for 1 kHz), the 1 Hz outputs (true position, fix, servo
    diagnostics) every 1000 steps."""
    scenario = variant(load("rotational_ins_navigation"), PAPER_RATE_VARIANT)
    return dataclasses.replace(scenario, duration_s=duration_s, **({} if seed is None else {"seed": seed}))


@functools.lru_cache(maxsize=None)
def _has_paper_rate(python: str) -> bool:
    """Whether the checkout of ``python`` runs the navigation scenario at its paper rate."""
    probe = "from gimbal_sim.tools.engine_speed import paper_rate_navigation"
    return subprocess.run([python, "-c", probe], capture_output=True, check=False).returncode == 0


def _script(python: str, case: str, duration_s: float, tail: str, *extra: str) -> dict[str, Any]:
    """Run ``case``'s script with ``tail`` by interpreter ``python``; its JSON."""
    if case == "rotational_ins_navigation" and _has_paper_rate(python):
        cmd = [python, "-c", NAV_ENGINE_SCRIPT + tail, str(duration_s), *extra]
    elif case == "rotational_ins_navigation":
        cmd = [python, "-c", NAV_SCRIPT + tail, str(duration_s), str(SUBSTEPS), *extra]
    elif case == NAV_RECORDED:
        cmd = [python, "-c", NAV_RECORD_SCRIPT + tail, str(duration_s), *extra]
    else:
        cmd = [python, "-c", CORE_SCRIPT + tail, case, str(duration_s), *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{case} with {python} failed (exit {proc.returncode}): {proc.stderr.strip()[-400:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def profile_report(python: str, duration_s: float, top: int = 15) -> str:
    """Each case once under cProfile by ``python``: its ``top`` functions by own time, as
    shares of the engine loop's time (own, cumulative) and their call counts."""
    lines = []
    for case, (label, _) in TARGETS.items():
        rows = _script(python, case, duration_s, PROFILED, str(top))["profile"]
        lines.append(f"{label}, {duration_s:g} s, {python}: own %  cumulative %  calls  function")
        lines.extend(f"  {100 * own:6.1f} {100 * cum:12.1f} {calls:>9,}  {name}" for own, cum, calls, name in rows)
    return "\n".join(lines)


def run_case(python: str, case: str, duration_s: float) -> dict[str, Any]:
    """One run of ``case`` by interpreter ``python``: its JSON figures plus steps_per_s."""
    out = _script(python, case, duration_s, TIMED)
    out["steps_per_s"] = out["steps"] / out["wall_s"]
    out["steps_per_cpu_s"] = out["steps"] / out["cpu_s"]
    return out


def _pairs(case: str, duration_s: float, pairs: int, baseline: str | None) -> dict[str, list[dict]]:
    """``case`` ``pairs`` times on each side, alternating which goes first."""
    runs: dict[str, list[dict]] = {"this": [], "baseline": []}
    for i in range(pairs):
        order = ("this", "baseline") if i % 2 == 0 else ("baseline", "this")
        for who in order:
            if who == "baseline" and baseline is None:
                continue
            runs[who].append(run_case(sys.executable if who == "this" else baseline, case, duration_s))
    return runs


def measure(duration_s: float, pairs: int, baseline: str | None, memory_factor: float | None,
            three_hours: bool = False) -> dict[str, Any]:
    """Every case ``pairs`` times (with the baseline, alternating the order), the recorded
    navigation run on this side, then the memory run (or one whole 3-hour run); the load
    average before and after."""
    result: dict[str, Any] = {"load_before": os.getloadavg()[0], "cases": {}}
    for case in TARGETS:
        result["cases"][case] = _pairs(case, duration_s, pairs, baseline)
        if case == "rotational_ins_navigation":
            result["recorded"] = _pairs(NAV_RECORDED, duration_s, pairs, None)["this"]
    if three_hours:
        result["memory"] = (run_case(sys.executable, "rotational_ins_navigation", duration_s),
                            run_case(sys.executable, "rotational_ins_navigation", THREE_HOURS_S))
    elif memory_factor is not None:
        result["memory"] = (run_case(sys.executable, "rotational_ins_navigation", duration_s),
                            run_case(sys.executable, "rotational_ins_navigation", duration_s * memory_factor))
    result["load_after"] = os.getloadavg()[0]
    return result


def _verdict(ok: bool) -> str:
    return "met" if ok else "MISSED"


def _row(label: str, value: str, base: str, ratio: str, target: str, verdict: str) -> str:
    return f"{label:<56} {value:>10} {base:>10} {ratio:>7} {target:>8}  {verdict}"


def _case_lines(case: str, runs: dict[str, list[dict]]) -> list[str]:
    label, target = TARGETS[case]
    this = median(r["steps_per_s"] for r in runs["this"])
    if not runs["baseline"]:
        return [_row(label, f"{this:,.0f}", "-", "-", f">= {target:g}x", "(no --baseline)")]
    base = median(r["steps_per_s"] for r in runs["baseline"])
    ratio = this / base
    cpu = median(r["steps_per_cpu_s"] for r in runs["this"]) / median(r["steps_per_cpu_s"] for r in runs["baseline"])
    return [_row(label, f"{this:,.0f}", f"{base:,.0f}", f"{ratio:.2f}x", f">= {target:g}x",
                 f"{_verdict(ratio >= target):<9} ({cpu:.2f}x)")]


def _navigation_lines(result: dict[str, Any], three_hours: bool) -> list[str]:
    """The 3-hour run (projected, or measured) and the cost of recording."""
    this = median(r["steps_per_s"] for r in result["cases"]["rotational_ins_navigation"]["this"])
    lines = []
    if three_hours:
        wall = result["memory"][1]["wall_s"]
        lines.append(_row("  one 3-hour run, measured (engine loop) [s]", f"{wall:,.0f}", "", "",
                          f"<= {THREE_HOUR_TARGET_S:g}", _verdict(wall <= THREE_HOUR_TARGET_S)))
    else:
        projected = THREE_HOURS_STEPS / this
        lines.append(_row("  one 3-hour run, projected from steps/s [s]", f"{projected:,.0f}", "", "",
                          f"<= {THREE_HOUR_TARGET_S:g}", _verdict(projected <= THREE_HOUR_TARGET_S)))
    recorded = result.get("recorded")
    if recorded:
        rec = median(r["steps_per_s"] for r in recorded)
        cost = this / rec
        cpu = median(r["steps_per_cpu_s"] for r in recorded)
        mb = median(r["bag_mb"] for r in recorded)
        lines.append(_row("  recorded to a bag (run_engine, bag closed)", f"{rec:,.0f}", "", f"{cost:.2f}x",
                          f"<= {RECORD_COST_TARGET:g}x", f"{_verdict(cost <= RECORD_COST_TARGET):<9} "
                          f"(cost as steps/s unrecorded / recorded; {cpu:,.0f} steps per CPU s; bag {mb:.1f} MB)"))
    return lines


def report(result: dict[str, Any], duration_s: float, memory_factor: float | None, three_hours: bool = False) -> str:
    """The figures, each against its target."""
    lines = [f"engine speed: lockstep steps/s of the engine loop (wall), {duration_s:g} s runs, median of "
             f"each side's runs; 1-min load average {result['load_before']:.2f} before, {result['load_after']:.2f} after",
             _row("case", "steps/s", "baseline", "ratio", "target", "verdict   (ratio of steps per CPU second)")]
    for case, runs in result["cases"].items():
        lines += _case_lines(case, runs)
        if case == "rotational_ins_navigation":
            lines += _navigation_lines(result, three_hours)
    if "memory" in result:
        short, long = result["memory"]
        long_s = THREE_HOURS_S if three_hours else duration_s * (memory_factor or 1.0)
        growth = long["peak_rss_mb"] / short["peak_rss_mb"] - 1.0
        lines.append(f"peak RSS, navigation {duration_s:g} s -> {long_s:g} s: "
                     f"{short['peak_rss_mb']:.0f} -> {long['peak_rss_mb']:.0f} MB ({100 * growth:+.1f} %), "
                     f"target within {100 * RSS_GROWTH_TARGET:g} %  {_verdict(abs(growth) <= RSS_GROWTH_TARGET)}")
    return "\n".join(lines)
