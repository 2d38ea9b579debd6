"""``python -m gimbal_sim.tools.no_regression``: every scenario recorded by two checkouts, and
their bags compared message by message (``docs/results/no_regression.md``).

Each checkout is a directory holding a ``.venv`` made by ``make venv``: the one under test
(default: this interpreter's) and ``--baseline``. Every built-in scenario of the checkout under
test whose data do not depend on the wall clock (a node in ``realtime`` or ``free`` timing, or a
MAVLink endpoint, is left out and listed; so is a variant that chains a prelude run of another
scenario), variant by variant, runs for ``--duration``
simulated seconds on each side in the graph (container mode) and, for the checkout under test,
on the engine too (``--engine core``, where the engine steps the scenario). Each new bag is
compared with the baseline's graph bag (:func:`..bag.compare.compare_bags`): "same data" (every
message's stamps and bytes), "within tolerance" (the largest relative deviation of any float
field, at most ``--rel-tol``) or DIFFERENT (the first topic that differs and where). A run that
writes its bag but not its report (a report that refuses so short a run) still counts: its bag
is compared. The table goes to stdout as Markdown; exit 0 when every pair is the same data or
within tolerance, 1 otherwise, 2 for bad arguments.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from ..bag.compare import compare_bags
from ..bag.reader import BagError
from ..graph.scenario import builtin_scenarios, load

#: A scenario's data depend on the wall clock when one of its nodes is paced by it.
CLOCKED_TIMINGS = {"realtime", "free"}


@dataclass(frozen=True)
class Case:
    scenario: str
    variant: str | None

    @property
    def label(self) -> str:
        return self.scenario + (f" ({self.variant})" if self.variant else "")

    @property
    def dir(self) -> str:
        """Its run directory's name (each variant its own run)."""
        return self.scenario + (f"@{self.variant}" if self.variant else "")


def cases() -> tuple[list[Case], list[str]]:
    """The scenarios to compare, variant by variant, and those left out (with why)."""
    out, skipped = [], []
    for name in sorted(builtin_scenarios()):
        scenario = load(name)
        timings = {spec["params"].get("timing", "lockstep") for spec in scenario.nodes.values()}
        if timings & CLOCKED_TIMINGS or any("mavlink" in n for n in scenario.nodes):
            skipped.append(f"{name}: paced by the wall clock (never the same data twice)")
            continue
        for v, overrides in scenario.variants.items():
            if "prelude" in overrides:  # its prelude is a whole other scenario's run, compared as itself
                skipped.append(f"{name} ({v}): chains a prelude run of {overrides['prelude']['scenario']}")
            else:
                out.append(Case(name, v))
        out += [] if scenario.variants else [Case(name, None)]
    return out, skipped


def record(checkout: Path, case: Case, out: Path, duration_s: float, engine: str, domain: int) -> Path:
    """Run one case with ``checkout``'s venv; the bag directory (which exists when the bag does)."""
    cmd = [str(checkout / ".venv" / "bin" / "gimbal-run"), case.scenario, "--mode", "container", "--engine", engine,
           "--duration", repr(duration_s), "--no-progress", "--out", str(out)]
    if engine == "graph":   # the baseline may predate --engine: its default is the graph
        cmd[4:6] = []
    if case.variant:
        cmd += ["--variant", case.variant]
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_name(out.name + ".log"), "w") as log:
        subprocess.run(cmd, env=env, cwd=checkout, stdout=log, stderr=subprocess.STDOUT, check=False)
    return out / case.variant if case.variant else out


def graph_only(topic: str) -> bool:
    """Topics only the graph carries (docs/architecture.md): the engine's bag has none."""
    return topic == "/diagnostics" or topic.endswith("/progress")


def verdict(a: Path, b: Path, rel_tol: float, engine: bool = False) -> tuple[bool, str, int]:
    """(acceptable, words, topics compared) for the bags ``a`` (baseline) and ``b``; against the
    engine's bag ``b``, the graph-only topics are left out."""
    if not (a / "metadata.yaml").exists():
        return True, "no baseline bag (a scenario or variant added since)", 0
    if not (b / "metadata.yaml").exists():
        return False, "NO BAG written", 0
    try:
        diff = compare_bags(a, b, rel_tol=rel_tol)
    except BagError as exc:
        return False, f"UNREADABLE: {exc}", 0
    topics = {n: t for n, t in diff.topics.items() if not (engine and graph_only(n) and t.count_b == 0)}
    if all(t.comparable and t.values_equal for t in topics.values()):
        return True, "same data", len(topics)
    if rel_tol > 0 and all(t.comparable and t.within_tolerance for t in topics.values()):
        worst = max(topics.values(), key=lambda t: t.max_rel)
        return True, f"within tolerance (largest relative deviation {worst.max_rel:.1e}, {worst.topic})", len(topics)
    bad = next(t for t in topics.values() if not (t.comparable and (t.values_equal or (rel_tol > 0 and t.within_tolerance))))
    if bad.count_a != bad.count_b:
        what = f"{bad.count_a} vs {bad.count_b} messages"
    else:
        what = f"{bad.first_difference or 'values'}; max rel {bad.max_rel:.1e}"
    return False, f"DIFFERENT: {bad.topic} ({what})", len(topics)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.no_regression", description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", required=True, type=Path, help="the reference checkout (with its .venv)")
    parser.add_argument("--checkout", type=Path, default=Path(sys.prefix).parent,
                        help="the checkout under test (default: the one whose venv runs this)")
    parser.add_argument("--out", required=True, type=Path, help="directory for both sides' runs (must not exist)")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated seconds per run (default 1)")
    parser.add_argument("--rel-tol", type=float, default=0.0, help="accepted relative deviation (default 0: the bits)")
    parser.add_argument("--scenario", action="append", help="only this scenario (repeatable)")
    args = parser.parse_args(argv)
    for side in (args.baseline, args.checkout):
        if not (side / ".venv" / "bin" / "gimbal-run").exists():
            parser.error(f"{side} has no .venv/bin/gimbal-run (run `make venv` there)")
    if args.out.exists():
        parser.error(f"--out {args.out} already exists; not overwriting it")
    if not args.duration > 0 or not args.rel_tol >= 0:
        parser.error("--duration must be > 0 and --rel-tol >= 0")
    todo, skipped = cases()
    if args.scenario:
        todo = [c for c in todo if c.scenario in args.scenario]
    rows, ok = [], True
    for i, case in enumerate(todo):
        print(f"[{i + 1}/{len(todo)}] {case.label}", file=sys.stderr)
        ref = record(args.baseline, case, args.out / "baseline" / case.dir, args.duration, "graph", 60)
        graph = record(args.checkout, case, args.out / "graph" / case.dir, args.duration, "graph", 61)
        engine = record(args.checkout, case, args.out / "engine" / case.dir, args.duration, "core", 62)
        g_ok, g_words, n = verdict(ref, graph, args.rel_tol)
        e_ok, e_words, _ = verdict(ref, engine, args.rel_tol, engine=True) if (engine / "metadata.yaml").exists() else (
            True, "not on the engine", 0)
        ok &= g_ok and e_ok
        rows.append(f"| {case.label} | {n} | {g_words} | {e_words} |")
    print(f"| scenario (variant) | topics | graph against the baseline | engine against the baseline |\n"
          f"| --- | ---: | --- | --- |")
    print("\n".join(rows))
    for line in skipped:
        print(f"\nLeft out: {line}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
