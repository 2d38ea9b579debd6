"""``gimbal-bench engine``: the no-ROS engine's speed at the papers' own 1 kHz loops, each
figure printed against its target, side by side with another checkout when ``--baseline``
names that checkout's Python (its venv's ``bin/python``).

Cases, each run in a subprocess (its memory its own) by this interpreter and by the
baseline's, alternating which goes first, the median of ``--pairs`` taken:

* ``rotational_ins_navigation`` at 1 kHz with the motors' full dynamics (RK4 over the
  armature, 4 substeps, instead of the quasi-static step the 5 Hz campaign uses): paper 3's
  platform, IMU, resolvers, servo and navigator (:func:`..experiments.navigation.run_navigation`);
* ``sighting_land_vehicle`` at 1 kHz (the core loop, :func:`..core.core_loop.run_core_loop`).

Each case runs a small script that only uses what older checkouts have too
(:data:`NAV_SCRIPT`, :data:`CORE_SCRIPT`), so the baseline runs the same work; each first
runs 10 ms (loading the compiled kernels from their cache), then times its run.
``--profile`` runs each case once under cProfile instead, on each side, and prints its
functions by own time (:func:`profile_report`). Figures: steps/s (engine loop, wall
time), the ratio to the baseline, the wall time of one 3-hour run projected from the
steps/s, and the peak RSS of a run ``--memory-factor`` times longer against the short one
(flat: within 10 %). The 1-minute load average is printed before and after: the wall-time
ratios are only meaningful on a quiet machine; the ratio of steps per CPU second, printed
beside them, moves less with the load.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from statistics import median
from typing import Any

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
THREE_HOURS_STEPS = 3 * 3600 * 1000
#: case -> (label, ratio target)
TARGETS = {"rotational_ins_navigation": ("rotational_ins_navigation, 1 kHz, full motor dynamics", 20.0),
           "sighting_land_vehicle": ("sighting_land_vehicle, 1 kHz", 10.0)}
THREE_HOUR_TARGET_S = 180.0
RSS_GROWTH_TARGET = 0.10


def _script(python: str, case: str, duration_s: float, tail: str, *extra: str) -> dict[str, Any]:
    """Run ``case``'s script with ``tail`` by interpreter ``python``; its JSON."""
    if case == "rotational_ins_navigation":
        cmd = [python, "-c", NAV_SCRIPT + tail, str(duration_s), str(SUBSTEPS), *extra]
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


def measure(duration_s: float, pairs: int, baseline: str | None, memory_factor: float | None) -> dict[str, Any]:
    """Every case ``pairs`` times (with the baseline, alternating the order), then the
    memory run; the load average before and after."""
    result: dict[str, Any] = {"load_before": os.getloadavg()[0], "cases": {}}
    for case in TARGETS:
        runs: dict[str, list[dict]] = {"this": [], "baseline": []}
        for i in range(pairs):
            order = ("this", "baseline") if i % 2 == 0 else ("baseline", "this")
            for who in order:
                if who == "baseline" and baseline is None:
                    continue
                runs[who].append(run_case(sys.executable if who == "this" else baseline, case, duration_s))
        result["cases"][case] = runs
    if memory_factor is not None:
        result["memory"] = (run_case(sys.executable, "rotational_ins_navigation", duration_s),
                            run_case(sys.executable, "rotational_ins_navigation", duration_s * memory_factor))
    result["load_after"] = os.getloadavg()[0]
    return result


def _verdict(ok: bool) -> str:
    return "met" if ok else "MISSED"


def report(result: dict[str, Any], duration_s: float, memory_factor: float | None) -> str:
    """The figures, each against its target."""
    lines = [f"engine speed: lockstep steps/s of the engine loop (wall), {duration_s:g} s runs, median of "
             f"each side's runs; 1-min load average {result['load_before']:.2f} before, {result['load_after']:.2f} after",
             f"{'case':<56} {'steps/s':>10} {'baseline':>10} {'ratio':>7} {'target':>8}  verdict   "
             f"(ratio of steps per CPU second)"]
    for case, runs in result["cases"].items():
        label, target = TARGETS[case]
        this = median(r["steps_per_s"] for r in runs["this"])
        if runs["baseline"]:
            base = median(r["steps_per_s"] for r in runs["baseline"])
            ratio = this / base
            cpu = median(r["steps_per_cpu_s"] for r in runs["this"]) / median(r["steps_per_cpu_s"]
                                                                            for r in runs["baseline"])
            lines.append(f"{label:<56} {this:>10,.0f} {base:>10,.0f} {ratio:>6.2f}x {'>= ' + f'{target:g}x':>8}  "
                         f"{_verdict(ratio >= target):<9} ({cpu:.2f}x)")
        else:
            lines.append(f"{label:<56} {this:>10,.0f} {'-':>10} {'-':>7} {'>= ' + f'{target:g}x':>8}  "
                         "(no --baseline)")
        if case == "rotational_ins_navigation":
            projected = THREE_HOURS_STEPS / this
            lines.append(f"{'  one 3-hour run, projected from steps/s [s]':<56} {projected:>10,.0f} {'':>10} {'':>7} "
                         f"{'<= ' + f'{THREE_HOUR_TARGET_S:g}':>8}  {_verdict(projected <= THREE_HOUR_TARGET_S)}")
    if memory_factor is not None:
        short, long = result["memory"]
        growth = long["peak_rss_mb"] / short["peak_rss_mb"] - 1.0
        lines.append(f"peak RSS, navigation {duration_s:g} s -> {duration_s * memory_factor:g} s: "
                     f"{short['peak_rss_mb']:.0f} -> {long['peak_rss_mb']:.0f} MB ({100 * growth:+.1f} %), "
                     f"target within {100 * RSS_GROWTH_TARGET:g} %  {_verdict(abs(growth) <= RSS_GROWTH_TARGET)}")
    return "\n".join(lines)
