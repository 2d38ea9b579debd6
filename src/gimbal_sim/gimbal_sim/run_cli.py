"""``gimbal-run``: the launch-free scenario orchestrator's entry point.

A scenario with ``variants`` runs once per variant, each into ``OUT/<variant>/`` (a complete
bag with its own report), and then writes the comparison report into ``OUT/report/``. With
``--jobs N`` up to N variants run at once, each as a child ``gimbal-run`` of the single
variant with a ROS domain id of its own (claimed here, so concurrent runs never meet).

A scenario (or variant) with a ``prelude`` runs two chained runs (graph or engine alike,
:func:`.experiments.engine_runs.run_chained`): the prelude scenario
first (same seed, its own duration), whose hand-off turns its run into a ROS 2 parameter
file applied to the scenario like ``--params-file`` (after the user's ``--set``); the
prelude's run ends up in the run's ``prelude/`` (bag, report, the parameter file) and the
hand-off's figures in the run's ``hand_off.json``, which the scenario's report reads.

Exit codes: 0 success; 1 the run failed (a node died or stalled; the bag is still
finalized) or the disk filled up (the bag closed at its last chunk on disk, run.json with
``stopped: disk full`` and the report of the simulated time written); 2 bad input (unknown
scenario or node, malformed --set, output exists, not enough free space for the run's
estimated size without --force), with nothing started and nothing overwritten; 130 Ctrl-C,
143 SIGTERM, 129 SIGHUP (the graph stopped in order, the bag closed, run.json with
``interrupted: true`` and the report of the simulated time written).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

from gimbal_kinematics.cli.boundary import Interrupted, UsageError, cli_boundary, finite, read_text, writable_dir
from gimbal_kinematics.ros.ros_domain import claim_domain_id, die_with_parent, localhost_env

from .bag.live import parse_topic_rates
from .bag.disk import (
    disk_error_line, estimate_run_bytes, free_bytes, human, is_disk_error, space_line, stop_kind,
)
from .bag.reader import scan
from .bag.writer import DiskStopped
from .core.core_loop import NoCoreError
from .core.engine_run import check_engine, run_engine
from .graph.orchestrator import PROGRESS_FILE_ENV, RunError, run, stop_processes
from .graph.plan import check_nodes
from .graph.scenario import PRELUDE_PREFIX, Scenario, apply_params_file, apply_set, describe_builtins, load, variant
from .page import PAGE
from .reports.dispatch import write_comparison, write_report
from .experiments.engine_runs import prelude_scenario, run_chained
from .reports.hand_off import write_figures


#: How long a child ``gimbal-run`` (--jobs) may take to keep its run after Ctrl-C [s].
CHILD_STOP_GRACE_S = 60.0


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
                        help="override a node parameter (value in YAML syntax; prelude.NODE.PARAM: a parameter of "
                             "the prelude's run, e.g. the same sensors in both runs of a chain); repeatable")
    parser.add_argument("--params-file", action="append", default=[], type=Path, metavar="FILE",
                        help="ROS 2 parameter file (node: {ros__parameters: {...}}, e.g. gimbal-allan's "
                             "sensor_models.yaml): each value overrides that node's parameter like --set, "
                             "before the --set ones; repeatable")
    parser.add_argument("--out", type=Path, help="run directory (default bags/<timestamp>_<scenario>)")
    parser.add_argument("--mode", choices=("processes", "container"), default="processes",
                        help="one OS process per node, or all nodes in this process (default processes)")
    parser.add_argument("--engine", choices=("graph", "core"), default="graph",
                        help="graph: the scenario's nodes (default); core: the same cores stepped in one Python "
                             "loop, no ROS, recording the same bag (same topics, stamps and bytes, without "
                             "/diagnostics and the nodes' progress; docs/architecture.md)")
    parser.add_argument("--variant", action="append", default=[], metavar="NAME",
                        help="run only this variant of a scenario that has variants; repeatable")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="run up to N variants at once, each in its own process and ROS domain (default 1)")
    parser.add_argument("--force", action="store_true",
                        help="run even when the output's disk has less free space than the run's estimated size "
                             "(a full disk then stops the run, keeping the bag up to there)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-compress", action="store_true",
                        help="store the bag's MCAP chunks uncompressed (default: zstd-compressed)")
    parser.add_argument("--live", action="store_true",
                        help="serve a live view of the run (Foxglove WebSocket, ws://127.0.0.1:PORT) for "
                             "Foxglove or Lichtblick; see docs/usage.md, 'Live view'")
    parser.add_argument("--live-port", type=int, default=8765, metavar="N", help="live view port (default 8765)")
    parser.add_argument("--live-rate-hz", type=float, default=50.0, metavar="HZ",
                        help="rate each topic is relayed at, decimated by stamp (default 50; 0: every message)")
    parser.add_argument("--live-topic-rate", action="append", default=[], metavar="TOPIC=HZ",
                        help="relay rate of one topic (0: every message); repeatable")
    return parser


def _live_params(args: argparse.Namespace) -> dict | None:
    """The recorder's live-view parameters, checked (the port must be free) before anything starts."""
    if not args.live:
        return None
    if not 1 <= args.live_port <= 65535:
        raise UsageError(f"--live-port must be in 1..65535, got {args.live_port}")
    finite(args.live_rate_hz, "--live-rate-hz", 0.0)
    try:
        parse_topic_rates(args.live_topic_rate)
    except ValueError as exc:
        raise UsageError(f"--live-topic-rate: {exc}") from None
    probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the live view binds it
    try:
        probe.bind(("127.0.0.1", args.live_port))
    except OSError as exc:
        raise UsageError(f"--live-port {args.live_port}: port {args.live_port} is not free ({exc.strerror}); "
                         f"another live view may be running on it, choose another with --live-port") from None
    finally:
        probe.close()
    return {"live_port": args.live_port, "live_rate_hz": args.live_rate_hz,
            "live_topic_rates": list(args.live_topic_rate)}


def _check_engine(runs: list[tuple[str, Scenario]], args: argparse.Namespace) -> None:
    """``--engine core``: every run's node set is one the engine steps, in lockstep (module
    docstring of :mod:`.core.engine_run`), refused before anything starts."""
    if args.live:
        raise UsageError("--live shows the graph's topics as they are published: drop it with --engine core")
    for name, single in runs:
        where = f"variant {name!r}: " if name else ""
        try:
            check_engine(single)
            if single.prelude:
                check_engine(prelude_scenario(single))
        except NoCoreError as exc:
            raise UsageError(f"--engine core: {where}{exc}") from None


def _print_list() -> None:
    builtins = describe_builtins()
    print("Built-in scenarios:")
    width = max((len(n) for n, _ in builtins), default=0)
    for name, text in builtins:
        print(f"  {name:<{width}}  {text}")


def summary_table(rows: list[tuple[str, str]]) -> str:
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)


def _check_inputs(args: argparse.Namespace) -> None:
    """The files and numbers the user gave, checked before anything is read or started."""
    if Path(args.scenario).suffix in (".yaml", ".yml") or Path(args.scenario).exists():
        read_text(args.scenario, "scenario file")
    for path in args.params_file:
        read_text(path, "--params-file")
    if args.duration is not None:
        finite(args.duration, "--duration", 0.0, strict=True)


def _check_space(out: Path, runs: list[Scenario], args: argparse.Namespace) -> None:
    """Refuse runs whose estimated bags and reports do not fit on ``out``'s disk, unless --force."""
    need = sum(estimate_run_bytes(s.duration_s + (s.prelude or {}).get("duration_s", 0.0), s.sim_rate_hz,
                                  not args.no_compress) for s in runs)
    if need > free_bytes(out) and not args.force:
        raise UsageError(f"--out {out}: not enough room: the run needs about {human(need)} (bag, report and the "
                         f"room to close the bag), and {space_line(out)}. Free some space, choose another --out, "
                         f"shorten --duration, or add --force to run until the disk is full (the bag is then "
                         f"kept up to there)")


def _variant_runs(scenario: Scenario, args: argparse.Namespace) -> tuple[Scenario, list[tuple[str, Scenario]]]:
    """``scenario`` with its ``--set`` applied, and its runs (variant name, single scenario);
    a prelude's parameters go to each run's own prelude, which a variant may give it."""
    to_prelude = [a for a in args.set if a.startswith(PRELUDE_PREFIX)]
    for assignment in args.set:
        if assignment not in to_prelude:
            scenario = apply_set(scenario, assignment)
    if args.variant and not scenario.variants:
        raise UsageError(f"scenario {scenario.name!r} has no variants; drop --variant")
    names = args.variant or list(scenario.variants)
    runs = [(name, variant(scenario, name)) for name in names] if scenario.variants else [("", scenario)]
    for assignment in to_prelude:
        runs = [(name, apply_set(single, assignment)) for name, single in runs]
    return scenario, runs


@cli_boundary("gimbal-run")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.list or args.scenario is None:
        _print_list()
        return 0
    _check_inputs(args)
    scenario = load(args.scenario)
    if args.duration is not None:
        scenario = dataclasses.replace(scenario, duration_s=args.duration)
    if args.seed is not None:
        if args.seed < 0:
            raise UsageError(f"--seed must be >= 0, got {args.seed}")
        scenario = dataclasses.replace(scenario, seed=args.seed)
    for path in args.params_file:
        scenario = apply_params_file(scenario, path)
    scenario, runs = _variant_runs(scenario, args)
    for name, single in runs:
        check_nodes(single, f"variant {name!r}: " if name else "")
    out = writable_dir(args.out or Path("bags") / f"{time.strftime('%Y%m%d-%H%M%S')}_{scenario.name}", "--out")
    if args.jobs < 1:
        raise UsageError(f"--jobs must be >= 1, got {args.jobs}")
    if args.engine == "core":
        _check_engine(runs, args)
    _check_space(out, [single for _, single in runs], args)
    if args.live and args.jobs > 1 and len(runs) > 1:
        raise UsageError("--live shows one run at a time: drop --jobs or pick one --variant")
    args.live_params = _live_params(args)
    for _, single in runs:
        if single.prelude:
            prelude_scenario(single)  # refused now, before any run starts

    rows, ok = [], True
    if args.jobs > 1 and len(runs) > 1:
        active: list = []
        try:
            if not _run_concurrently(runs, out, args, rows, active):
                return 1
        except KeyboardInterrupt:
            stop_processes([proc for _, proc, *_ in active], grace_s=CHILD_STOP_GRACE_S)
            raise Interrupted(f"stopped the variants still running ({', '.join(n for n, *_ in active) or 'none'}); "
                              f"each keeps its bag, run.json (interrupted: true) and report in {out}/<variant>"
                              + "".join(f"\npage: {p}" for p in sorted(out.glob(f"*/report/{PAGE}")))) from None
    else:
        for i, (name, single) in enumerate(runs):
            bag = out / name if name else out
            if name:
                print(f"== variant {name} ({i + 1}/{len(runs)})", file=sys.stderr)
            try:
                metrics, row = _run_one(single, bag, args)
            except RunError as exc:
                print(f"gimbal-run: run failed: {exc}\nThe bag so far is in {bag}.", file=sys.stderr)
                return 1
            ok = ok and metrics["closed_cleanly"]
            rows += [(f"{name}: {k}" if name else k, v) for k, v in row]
            if metrics.get("stopped"):
                print(summary_table(rows), flush=True)
                print(_stopped_line(metrics, single, bag), file=sys.stderr)
                return 1
            if metrics.get("interrupted"):
                print(summary_table(rows), flush=True)  # before the interruption's line (stderr), the page's last
                closed = "closed cleanly" if metrics["closed_cleanly"] else "NOT closed cleanly"
                raise Interrupted(f"stopped the run at {metrics['sim_s']:g} s of {single.duration_s:g} s simulated; "
                                  f"kept the bag ({closed}), run.json (interrupted: true) and the report in {bag}"
                                  + (f"; variants not run: {', '.join(n for n, _ in runs[i + 1:])}"
                                     if runs[i + 1:] else "") + f"\npage: {bag / 'report' / PAGE}")
    if scenario.variants:
        (out / "scenario.yaml").write_text(scenario.to_yaml())
        report_dir, comparison = write_comparison(out, scenario.comparison, {n: out / n for n, _ in runs})
        rows.append(("comparison", f"{report_dir}/metrics.json + {len(comparison.get('plots', []))} plots"))
        if comparison.get("table"):
            print(comparison["table"])
    print(summary_table(rows))
    print(f"page: {out / 'report' / PAGE}")
    return 0 if ok else 1


def _run_concurrently(runs: list[tuple[str, Scenario]], out: Path, args: argparse.Namespace,
                      rows: list[tuple[str, str]], active: list) -> bool:
    """Each variant as a child ``gimbal-run`` of its single scenario into ``out/<name>``, up to
    ``args.jobs`` at a time, each in a ROS domain claimed here; appends the children's summary
    rows to ``rows``; ``active`` holds the running children (name, process, ...). False when
    a child failed (its log is printed)."""
    from tqdm import tqdm

    out.mkdir(parents=True)
    pending, failed, done = list(runs), [], {}
    # one bar per variant, fed from the sim time each child keeps in a file
    bars = {name: tqdm(total=round(single.duration_s, 3), desc=name, position=i, unit="sim s", file=sys.stderr,
                       disable=None if not args.no_progress else True, leave=True,
                       bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]")
            for i, (name, single) in enumerate(runs)}
    while pending or active:
        while pending and len(active) < args.jobs:
            name, single = pending.pop(0)
            spec = out / f".{name}.scenario.yaml"  # the variant as a plain scenario for the child
            spec.write_text(single.to_yaml())
            claim = claim_domain_id()
            env = dict(localhost_env(dict(os.environ)), ROS_DOMAIN_ID=str(claim.domain_id))
            env[PROGRESS_FILE_ENV] = str(out / f".{name}.progress")
            log_path = out / f".{name}.log"
            with open(log_path, "w") as log:  # the child keeps its own handle
                proc = subprocess.Popen([sys.executable, "-m", "gimbal_sim.run_cli", str(spec), "--out",
                                         str(out / name), "--mode", args.mode, "--engine", args.engine,
                                         "--no-progress",
                                         *(["--no-compress"] if args.no_compress else [])],
                                        env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        preexec_fn=die_with_parent())
            tqdm.write(f"== variant {name}: started (ROS domain {claim.domain_id}, log {log_path})", file=sys.stderr)
            active.append((name, proc, claim, log_path, spec))
        time.sleep(0.2)
        for name, *_ in active:
            try:
                bars[name].n = min(float((out / f".{name}.progress").read_text()), bars[name].total)
                bars[name].refresh()
            except (OSError, ValueError):  # not written yet, or caught mid-write
                pass
        for item in [a for a in active if a[1].poll() is not None]:
            name, proc, claim, log_path, spec = item
            active.remove(item)
            claim.release()
            text = log_path.read_text()
            (out / f".{name}.progress").unlink(missing_ok=True)
            if proc.returncode != 0:
                failed.append(name)
                print(f"gimbal-run: variant {name} failed (exit {proc.returncode}):\n{text[-3000:]}", file=sys.stderr)
                continue
            log_path.unlink()
            spec.unlink()
            bars[name].n = bars[name].total
            bars[name].refresh()
            tqdm.write(f"== variant {name}: done", file=sys.stderr)
            # the child's summary table: "  key  value" lines
            done[name] = [(f"{name}: {k.strip()}", v.strip()) for k, _, v in
                          (line.strip().partition("  ") for line in text.splitlines() if line.startswith("  "))]
    for bar in bars.values():
        bar.close()
    if failed:
        print(f"gimbal-run: variant(s) {', '.join(failed)} failed; the bags so far are in {out}", file=sys.stderr)
        return False
    for name, _ in runs:
        rows += done[name]
    return True


def _hand_off_row(figures: dict) -> tuple[str, str]:
    e, n, u = figures["residual_misalignment_arcsec"]
    return "hand-off", f"at {figures['hand_off_s']:g} s, residual misalignment E {e:.2f}″, N {n:.2f}″, U {u:.1f}″"


def _run_one(scenario: Scenario, out: Path, args: argparse.Namespace) -> tuple[dict, list[tuple[str, str]]]:
    """Run one scenario (after its prelude, if it has one) into ``out``, write its run.json
    and report; returns the report's metrics and the summary rows."""
    if not scenario.prelude:
        return _run_graph(scenario, out, args)
    metrics, figures, prelude_rows, rows = run_chained(scenario, out, lambda s, o, h: _run_graph(s, o, args, h))
    return metrics, prelude_rows + [_hand_off_row(figures)] + rows


def _run_engine(scenario: Scenario, out: Path, args: argparse.Namespace,
                hand_off: dict | None = None) -> tuple[dict, list[tuple[str, str]]]:
    """:func:`_run_graph` on the engine (``--engine core``): its bag, run.json, report and page."""
    if not args.no_progress:
        print(f"stepping {scenario.name} on the engine ({scenario.duration_s:g} s simulated) ...", file=sys.stderr)
    try:
        done = run_engine(scenario, out, compress=not args.no_compress)
    except DiskStopped as exc:  # the bag is closed at its last chunk on disk
        raise RunError(f"{exc}; the engine stopped there") from None
    if hand_off is not None:
        write_figures(out, hand_off)
    report_dir, metrics = write_report(out)
    return metrics, [
        ("scenario", f"{scenario.name} (engine core, seed {scenario.seed})"),
        ("simulated", f"{done.result.sim_s:.3f} s at {scenario.sim_rate_hz:g} Hz"),
        ("wall time", f"{done.wall_s:.2f} s (real-time factor {done.result.sim_s / done.wall_s:.2f}, "
                      f"{done.result.steps / done.wall_s:,.0f} steps/s)"),
        ("recorded", f"{metrics['message_count']} messages on {len(metrics['topics'])} topics, "
                     f"{'closed cleanly' if metrics['closed_cleanly'] else 'NOT closed cleanly'}"),
        ("bag", str(out)),
        ("report", f"{report_dir}/metrics.json + {len(metrics.get('plots', []))} plots"),
    ]


def _run_graph(scenario: Scenario, out: Path, args: argparse.Namespace,
               hand_off: dict | None = None) -> tuple[dict, list[tuple[str, str]]]:
    """:func:`_run_one` without a prelude; ``hand_off``: the prelude's hand-off figures,
    written into ``out`` for the report."""
    if args.engine == "core":
        return _run_engine(scenario, out, args, hand_off)
    result = run(scenario, out, args.mode, progress=not args.no_progress, compress=not args.no_compress,
                 live=args.live_params)
    if result.interrupted or result.stopped:
        # the nodes stepped on while they were being stopped: the run is what the bag holds
        contents = scan(out)
        if contents.start_ns is not None:
            result.sim_s = (contents.end_ns - contents.start_ns) * 1e-9
    if hand_off is not None:
        write_figures(out, hand_off)
    (out / "run.json").write_text(json.dumps({
        "scenario": scenario.name, "mode": args.mode, "seed": scenario.seed, "compressed": not args.no_compress,
        "sim_s": result.sim_s, "interrupted": result.interrupted,
        **({"stopped": stop_kind(result.stopped), "stop_reason": result.stopped} if result.stopped else {}),
        "wall_s": result.wall_s, "real_time_factor": result.real_time_factor,
        "steps_per_s": result.sim_s * scenario.sim_rate_hz / result.wall_s if result.wall_s > 0 else None,
        "processes": {k: dataclasses.asdict(v) if dataclasses.is_dataclass(v) else v
                      for k, v in (result.processes or {}).items()},
    }, indent=2, default=str) + "\n")
    report_dir, metrics = _write_report(out, result.stopped)
    if result.interrupted or result.stopped:
        metrics = dict(metrics, interrupted=result.interrupted, sim_s=result.sim_s, stopped=result.stopped)
    return metrics, [
        ("scenario", f"{scenario.name} ({args.mode} mode, seed {scenario.seed})"),
        ("simulated", f"{result.sim_s:.3f} s at {scenario.sim_rate_hz:g} Hz"),
        ("wall time", f"{result.wall_s:.2f} s (real-time factor {result.real_time_factor:.2f})"),
        ("recorded", f"{metrics['message_count']} messages on {len(metrics['topics'])} topics, "
                     f"{'closed cleanly' if metrics['closed_cleanly'] else 'NOT closed cleanly'}"),
        ("bag", str(out)),
        ("report", f"{report_dir}/metrics.json + {len(metrics.get('plots', []))} plots" if report_dir else "none: no room"),
    ]


def _stopped_line(metrics: dict, scenario: Scenario, bag: Path) -> str:
    """The one line of a run a full disk stopped: why (the device, its free space), how far, what was kept."""
    closed = "closed cleanly" if metrics["closed_cleanly"] else "NOT closed cleanly"
    return (f"gimbal-run: {metrics['stopped']}; stopped the run at {metrics['sim_s']:g} s of {scenario.duration_s:g} s "
            f"simulated and kept the bag ({closed}), run.json (stopped: {stop_kind(metrics['stopped'])}) and "
            f"{'the report' if metrics.get('report') else 'no report (no room for it)'} in {bag}")


def _write_report(out: Path, stopped: str | None) -> tuple[Path | None, dict]:
    """The run's report and its metrics; after a full disk, a report there is no room for is
    said so (the bag and run.json are kept), with the bag's own counts as the metrics."""
    try:
        report_dir, metrics = write_report(out)
        return report_dir, dict(metrics, report=True)
    except OSError as exc:
        if not stopped or not is_disk_error(exc):
            raise
        print(f"gimbal-run: no room for the report: {disk_error_line(exc, out)}", file=sys.stderr)
        contents = scan(out)
        return None, {"message_count": contents.message_count, "topics": contents.topics,
                      "closed_cleanly": contents.closed_cleanly, "report": False}


if __name__ == "__main__":
    sys.exit(main())
