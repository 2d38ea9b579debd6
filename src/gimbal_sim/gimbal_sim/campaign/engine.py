"""The campaign engine: every run of a campaign as one Dask task, results in one table.

``run_campaign(spec, out_dir)`` plans the runs with the ``plan`` it is handed (:func:`.spec.plan` for a scenario campaign), submits the ones
without results to a Dask cluster (an embedded ``LocalCluster`` on 127.0.0.1 sized to the
cores, or ``scheduler="tcp://host:port"``), and writes the campaign directory::

    OUT/campaign.yaml        what was asked, and the fingerprint a --resume must match
    OUT/runs/<run_id>/       one run: bag, params/, logs/, scenario.yaml, run.json,
                             report/metrics.json, and result.json (the run's row)
    OUT/results.parquet      one row per run (also results.csv): run id, variant, seed,
                             swept values (sweep.<node.param>), status, reason, wall time,
                             every numeric metric of the run's report (dotted paths)
    OUT/report/              the campaign report (the ``report`` it is handed: :mod:`.report`)

A task (:func:`execute_run`) runs on whichever worker gets it. Engine ``graph`` runs the
real node graph as a child ``gimbal-run`` of the single-run scenario, in a ROS domain
claimed on that host with discovery kept on it; engine ``core`` steps the same cores in
the worker (the ``core_run`` it is handed), which records the same bag; a caller's own ``run_fn(task, run_dir) -> metrics``
replaces both (the hook for the experiment runners). Each attempt writes into a fresh
``runs/.attempts/<id>-<token>/<id>/`` and is renamed to ``runs/<id>/`` only when complete, so a
task Dask reschedules after its worker died starts clean, and a half-done attempt never
looks like a result. A run that fails (a node died, a timeout, bad metrics) gets a row
with its reason and log tail; the campaign carries on.
"""
from __future__ import annotations

import json
import logging
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import traceback
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import yaml

from gimbal_kinematics.ros.ros_domain import claim_domain_id, die_with_parent

from ..bag.writer import add_custom_data
from ..graph.scenario import Scenario, validate
from .results import RESULT_FILE, CampaignResult, flatten_metrics, read_results, results_digest, write_results
from .spec import (
    LARGE_RUNS, MAX_ESTIMATE_S, WALL_PER_SIM_S, CampaignError, CampaignPlan, CampaignSpec, RunFunction, RunTask,
)

CONNECT_TIMEOUT_S = 5.0           # an unreachable scheduler is refused within this
STOP_GRACE_S = 20.0               # a timed-out gimbal-run gets this long to close its bag after SIGINT
LOG_TAIL_LINES = 25
_SCHEDULER = re.compile(r"^(tcp|tls)://[^\s/:]+:\d{1,5}$")


#: The core engine's run of a scenario: (scenario, run_dir to create, compress the bag) -> the
#: run's metrics (its bag and report in run_dir, like a graph run's).
CoreRun = Callable[[Scenario, Path, bool], dict]


@dataclass(frozen=True)
class Runners:
    """What the engine is handed to run a task: ``run_fn`` (a caller's own run, e.g. an
    experiment runner's core loop) or, for a scenario campaign's ``engine: core`` run,
    ``core_run(scenario, run_dir) -> metrics`` (the core engine with its report's metrics).
    Module-level functions (or partials of them): Dask pickles them."""

    run_fn: RunFunction | None = None
    core_run: CoreRun | None = None


# ------------------------------------------------------------------ the task (worker side)
def _stop_child(proc: subprocess.Popen) -> None:
    """SIGINT the child ``gimbal-run`` by PID (it closes its bag and stops its nodes); SIGKILL
    it when it outlives the grace time."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=STOP_GRACE_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _tail(text: str, lines: int = LOG_TAIL_LINES) -> str:
    return "\n".join(text.splitlines()[-lines:])


def _run_graph(task: RunTask, attempt: Path) -> tuple[str, str]:
    """``gimbal-run`` of the task's scenario into ``attempt``; returns (failure reason or "",
    log tail). The child gets a ROS domain claimed on this host; its lock is passed to the
    child so that the id stays taken for as long as the child lives."""
    scenario_file, log_file = attempt.parent / "scenario.yaml", attempt.parent / "gimbal-run.log"
    scenario_file.write_text(task.scenario_yaml)
    claim = claim_domain_id()
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_STATIC_PEERS", "GIMBAL_RUN_PROGRESS_FILE")}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(claim.domain_id))
    cmd = [sys.executable, "-m", "gimbal_sim.run_cli", str(scenario_file), "--out", str(attempt),
           "--mode", task.mode, "--no-progress", *([] if task.compress else ["--no-compress"])]
    reason = ""
    lock_fd = claim._lock_file.fileno()  # noqa: SLF001 - the flock must outlive this process's copy
    try:
        with open(log_file, "w") as log:
            proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    preexec_fn=die_with_parent(), pass_fds=(lock_fd,))
        try:
            code = proc.wait(timeout=task.timeout_s)
            if code != 0:
                reason = f"gimbal-run exited with code {code}"
        except subprocess.TimeoutExpired:
            _stop_child(proc)
            reason = f"timed out after {task.timeout_s:g} s"
        except KeyboardInterrupt:  # a stop signal to this process alone (SIGTERM): the run stops too
            _stop_child(proc)
            raise
    finally:
        claim.release()
    text = log_file.read_text(errors="replace")
    (attempt / "logs").mkdir(parents=True, exist_ok=True)
    log_file.replace(attempt / "logs" / "gimbal-run.log")
    return reason, _tail(text)


def _check_metrics(run_dir: Path, engine: str) -> tuple[dict[str, Any] | None, str]:
    """The run's report metrics, or None and why they are unusable."""
    path = run_dir / "report" / "metrics.json"
    if not path.is_file():
        return None, "no report/metrics.json"
    try:
        metrics = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        return None, f"report/metrics.json unreadable: {exc}"
    if not isinstance(metrics, dict):
        return None, "report/metrics.json is not a mapping"
    if engine in ("graph", "core") and not metrics.get("closed_cleanly", False):
        return metrics, f"bag not closed cleanly ({metrics.get('read_error')})"
    return metrics, ""


def _drop_bag(run_dir: Path) -> bool:
    """Delete the run's bag (MCAP and metadata.yaml), keeping its report; True if one was there."""
    found = False
    for path in [*run_dir.glob("*.mcap"), run_dir / "metadata.yaml"]:
        if path.is_file():
            path.unlink()
            found = True
    return found


def _checked_as(task: RunTask, run_fn: Any) -> str:
    """How a run's output is checked: a scenario run on either engine leaves a bag to check;
    an experiment runner's graph run does too, its core loop leaves none ("custom", as a
    caller's own run function)."""
    if run_fn is not None and (not task.experiment or task.engine == "core"):
        return "custom"
    return task.engine


def execute_run(task: RunTask, runners: Runners) -> dict[str, Any]:
    """Run one task where it lands (a Dask worker, or this process) and return its row.

    Never raises for a failed run: the row says ``status: failed`` with the reason and the
    log tail. Writes ``runs/<id>/`` (via an attempt directory renamed when complete)."""
    runs = Path(task.campaign_dir) / "runs"
    final = runs / task.run_id
    if (final / RESULT_FILE).is_file():  # an earlier attempt of this task completed it
        return json.loads((final / RESULT_FILE).read_text())
    # named like the run, so that the bag inside is <id>_0.mcap; its parent is the attempt's own
    attempt = runs / ".attempts" / f"{task.run_id}-{uuid.uuid4().hex[:8]}" / task.run_id
    attempt.parent.mkdir(parents=True)
    t0 = time.monotonic()
    reason, log_tail, metrics = "", "", None
    run_fn = runners.run_fn
    try:
        if run_fn is not None:
            attempt.mkdir(parents=True)
            run_fn(task, attempt)
        elif task.engine == "graph":
            reason, log_tail = _run_graph(task, attempt)
        else:
            runners.core_run(validate(yaml.safe_load(task.scenario_yaml), task.scenario_name), attempt, task.compress)
        engine = _checked_as(task, run_fn)
        metrics, why = _check_metrics(attempt, engine) if not reason or attempt.exists() else (None, "")
        reason = reason or why
    except Exception as exc:  # noqa: BLE001 - any failure of one run is recorded, the campaign goes on
        reason = f"{type(exc).__name__}: {exc}"
        log_tail = _tail(traceback.format_exc())
    attempt.mkdir(parents=True, exist_ok=True)
    engine_label = "custom" if run_fn is not None and not task.experiment else task.engine
    status = "failed" if reason else "ok"
    bag_kept = any(attempt.glob("*.mcap"))
    if bag_kept and (attempt / "metadata.yaml").is_file():  # the drawn values travel with the bag
        add_custom_data(attempt, {"campaign.run_id": task.run_id, "campaign.seed": str(task.seed),
                                  **{f"campaign.value.{k}": json.dumps(v) for k, v in task.values.items()}})
    if bag_kept and (task.keep_bags == "none" or (task.keep_bags == "failed" and status == "ok")):
        bag_kept = not _drop_bag(attempt)
    row = {"run_id": task.run_id, "scenario": task.scenario_name.split(":")[0], "variant": task.variant,
           "seed": task.seed, "engine": engine_label, "status": status,
           "reason": reason, "wall_s": time.monotonic() - t0, "host": socket.gethostname(),
           "log_tail": log_tail if status != "ok" else "", "values": task.values, "bag_kept": bag_kept,
           "metrics": flatten_metrics(metrics) if metrics else {}}
    (attempt / RESULT_FILE).write_text(json.dumps(row, indent=1, default=float) + "\n")
    try:
        attempt.rename(final)
    except OSError:  # another attempt finished first (a task run twice): keep the one that is there
        if not (final / RESULT_FILE).is_file():
            raise  # something else is in the way: keep this attempt where it is, and say so
        row = json.loads((final / RESULT_FILE).read_text())
    shutil.rmtree(attempt.parent, ignore_errors=True)
    return row


# ------------------------------------------------------------------ the campaign (client side)
def _tasks(campaign: CampaignPlan, out_dir: Path, spec: CampaignSpec) -> list[RunTask]:
    timeout = spec.timeout_s or 120.0 + 10.0 * (campaign.base.duration_s if campaign.base else 0.0)
    options = campaign.fingerprint.get("options", {})
    return [RunTask(r.run_id, str(out_dir), r.scenario.to_yaml() if r.scenario else "",
                    r.scenario.name if r.scenario else spec.experiment, r.variant, r.seed, r.values, spec.engine,
                    spec.mode, spec.compress, spec.keep_bags, timeout, spec.experiment, options)
            for r in campaign.runs]


def _load_row(out_dir: Path, run_id: str) -> dict[str, Any] | None:
    path = out_dir / "runs" / run_id / RESULT_FILE
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def check_directory(out_dir: Path, campaign: CampaignPlan, resume: bool) -> None:
    """Refuse an existing directory without ``resume``, and a resume of a different campaign."""
    if not out_dir.exists():
        return
    if not resume:
        raise CampaignError(f"--out {out_dir}: campaign directory already exists; add --resume to continue it")
    stored = out_dir / "campaign.yaml"
    if not stored.is_file():
        raise CampaignError(f"--resume: {out_dir} holds no campaign.yaml; not a campaign directory")
    old = (yaml.safe_load(stored.read_text()) or {}).get("fingerprint", {})
    new = json.loads(json.dumps(campaign.fingerprint))  # the YAML round trip's types
    differ = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    if differ:
        raise CampaignError(f"--resume: {out_dir} is a different campaign ({', '.join(differ)} differ: "
                            f"{ {k: old.get(k) for k in differ} } there, { {k: new.get(k) for k in differ} } asked)")


def connect(scheduler: str | None, workers: int | None) -> tuple[Any, Any]:
    """A Dask client: to ``scheduler`` (refused within :data:`CONNECT_TIMEOUT_S` when it does
    not answer), or to a new LocalCluster on 127.0.0.1 with ``workers`` single-threaded
    worker processes (default: one per core). Returns (client, cluster or None)."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        if not _SCHEDULER.match(scheduler):
            raise CampaignError(f"--scheduler {scheduler!r}: expected tcp://host:port")
        try:
            return Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s"), None
        except (OSError, TimeoutError) as exc:
            raise CampaignError(f"--scheduler {scheduler}: unreachable ({type(exc).__name__}: {exc})") from None
    n = workers or len(os.sched_getaffinity(0))
    # processes, one thread each: a core run holds the GIL for its whole run; everything on
    # loopback, the dashboard too (any free port, so that two campaigns never collide)
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="run", desc="campaign", file=sys.stderr, disable=None if enabled else True,
                bar_format="{l_bar}{bar}| {n}/{total} runs [{elapsed}<{remaining}{postfix}]")


def _cleanup(out_dir: Path) -> None:
    """Remove what attempts of completed runs left behind (a worker killed mid-run)."""
    runs = out_dir / "runs"
    for path in (runs / ".attempts").glob("*-*"):
        if (runs / path.name.split("-")[0] / RESULT_FILE).is_file():
            shutil.rmtree(path, ignore_errors=True)
    try:
        (runs / ".attempts").rmdir()  # only when empty
    except OSError:
        pass


def _run_dask(client: Any, todo: list[RunTask], runners: Runners, on_row, show) -> None:
    """Submit every task (in plan order), hand each finished one's row to ``on_row``, and
    ``show(running)`` the number of our tasks the workers are processing every 5 s."""
    nonce = uuid.uuid4().hex[:8]
    futures = {client.submit(execute_run, task, runners, key=f"gimbal-campaign-{nonce}-{task.run_id}",
                             pure=False): task for task in todo}
    keys = {f.key for f in futures}
    pending = dict(futures)
    next_poll = 0.0
    while pending:
        for future in [f for f in pending if f.status in ("finished", "error", "cancelled")]:
            task = pending.pop(future)
            try:
                row = future.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: the run failed, named
                row = failed_row(task, f"task failed on the cluster: {type(exc).__name__}: {exc}")
            on_row(row)
        if time.monotonic() >= next_poll:
            next_poll = time.monotonic() + 5.0  # a scheduler round trip: not more often
            try:
                show(sum(len(keys.intersection(k)) for k in client.processing().values()))
            except Exception:  # noqa: BLE001 - the count is cosmetic: keep the last one
                show()
        if pending:
            time.sleep(0.2)


def failed_row(task: RunTask, reason: str) -> dict[str, Any]:
    return {"run_id": task.run_id, "scenario": task.scenario_name.split(":")[0], "variant": task.variant,
            "seed": task.seed, "engine": task.engine, "status": "failed", "reason": reason, "wall_s": None,
            "host": "", "log_tail": "", "values": task.values, "bag_kept": False, "metrics": {}}


class _Progress:
    """The campaign's progress bar and the rows as they come in (``on_row``)."""

    def __init__(self, out_dir: Path, rows: dict[str, dict[str, Any]], total: int, enabled: bool) -> None:
        self.out_dir, self.rows = out_dir, rows
        self.bar = _progress(total, enabled)
        self.failed = self.running = 0

    def show(self, now_running: int | None = None) -> None:
        self.running = self.running if now_running is None else now_running
        self.bar.set_postfix_str(f"failed {self.failed}, running {self.running}", refresh=True)

    def on_row(self, row: dict[str, Any]) -> None:
        self.rows[row["run_id"]] = row
        path = self.out_dir / "runs" / row["run_id"] / RESULT_FILE
        if not path.is_file():  # the worker's disk is not ours: keep the row here
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(row, indent=1, default=float) + "\n")
        if row["status"] != "ok":
            self.failed += 1
            self.bar.write(f"run {row['run_id']} ({row['variant'] or '-'}, seed {row['seed']}) failed: "
                           f"{row['reason']}", file=sys.stderr)
        self.bar.update(1)
        self.show()


def _resumed_rows(out_dir: Path, campaign: CampaignPlan, resume: bool) -> dict[str, dict[str, Any]]:
    """The rows of runs that already succeeded (``resume``); an earlier failure's run
    directory is kept beside (``<id>.failed-<time>``) and the run goes again."""
    rows: dict[str, dict[str, Any]] = {}
    for run in campaign.runs:
        row = _load_row(out_dir, run.run_id) if resume else None
        if row is not None and row.get("status") == "ok":
            rows[run.run_id] = row
        elif row is not None:
            stamp = time.strftime("%Y%m%d-%H%M%S")
            (out_dir / "runs" / run.run_id).rename(out_dir / "runs" / f"{run.run_id}.failed-{stamp}")
    return rows


def _execute(todo: list[RunTask], runners: Runners, client: Any, bar: _Progress) -> None:
    """Every task of ``todo``, serially here (``client`` None) or on the Dask cluster."""
    try:
        if client is None:
            for task in todo:
                bar.show(1)
                try:
                    row = execute_run(task, runners)
                except OSError as exc:  # its attempt could not be put in place: kept, named
                    row = failed_row(task, f"{type(exc).__name__}: {exc}")
                bar.on_row(row)
        else:
            _run_dask(client, todo, runners, bar.on_row, bar.show)
    finally:
        bar.bar.close()


def _check_size(runs: int, large: bool) -> None:
    if runs > LARGE_RUNS and not large:
        raise CampaignError(f"{runs:,} runs: more than {LARGE_RUNS:,}; add --large if that many is meant")


def estimate_wall_s(campaign: CampaignPlan, out_dir: Path, resume: bool, workers: int) -> tuple[float, str] | None:
    """The campaign's own estimate of its wall time [s] and how it was made: the runs still to
    do times a run's wall time, over ``workers``. A run's wall time is the mean of the runs
    this campaign already finished (``resume``), else :data:`WALL_PER_SIM_S` of its engine
    times the simulated duration. None for an experiment runner's runs (no duration known)."""
    if campaign.base is None:
        return None
    rows = [row for r in campaign.runs if resume and (row := _load_row(out_dir, r.run_id)) is not None
            and row.get("status") == "ok"]
    todo = len(campaign.runs) - len(rows)
    walls = [row["wall_s"] for row in rows if isinstance(row.get("wall_s"), (int, float))]
    if walls:
        per_run, how = sum(walls) / len(walls), f"the mean of the {len(walls)} runs it finished"
    else:
        factor = WALL_PER_SIM_S[campaign.spec.engine]
        per_run = factor * campaign.base.duration_s
        how = f"{factor:.3g} s of wall per simulated s, {campaign.spec.engine} engine (docs/campaigns.md)"
    return todo * per_run / max(workers, 1), f"{todo:,} runs x {per_run:,.0f} s ({how}) / {workers} worker(s)"


def _check_estimate(campaign: CampaignPlan, out_dir: Path, resume: bool, workers: int, large: bool) -> None:
    """A campaign estimated to take more than :data:`MAX_ESTIMATE_S` needs ``--large``."""
    estimate = estimate_wall_s(campaign, out_dir, resume, workers)
    if estimate is not None and estimate[0] > MAX_ESTIMATE_S and not large:
        raise CampaignError(f"this campaign would take about {estimate[0] / 3600.0:,.1f} h by its own estimate "
                            f"({estimate[1]}): more than {MAX_ESTIMATE_S / 3600.0:g} h; add --large if that "
                            f"is meant, or run fewer seeds or a shorter --duration")


def _finished_rows(out_dir: Path, campaign: CampaignPlan, rows: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Every run with a result on disk or received, in plan order: a worker may have written
    its result after the client stopped listening (Ctrl-C), and that run is done too."""
    for run in campaign.runs:
        if run.run_id not in rows and (row := _load_row(out_dir, run.run_id)) is not None:
            rows[run.run_id] = row
    return [rows[r.run_id] for r in campaign.runs if r.run_id in rows]


def _report_is_current(out_dir: Path) -> bool:
    """Was ``report/`` written from the results table now on disk? Its ``summary.json``
    holds the digest of the table it was written from (:func:`~.results.results_digest`)."""
    try:
        summary = json.loads((out_dir / "report" / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    return summary.get("results_digest") == results_digest(read_results(out_dir))


def run_campaign(spec: CampaignSpec, out_dir: Path, *, plan: Callable[[CampaignSpec], CampaignPlan],
                 report: Callable[[Path], Any], runners: Runners = Runners(), resume: bool = False,
                 scheduler: str | None = None, workers: int | None = None, serial: bool = False,
                 progress: bool = True, large: bool = False) -> CampaignResult:
    """Run the campaign ``spec`` into ``out_dir`` (module docstring): ``plan(spec)`` expands
    it into runs, ``runners`` run them, ``report(out_dir)`` writes the campaign report.
    ``serial`` runs the tasks one by one in this process (no Dask). Raises
    :class:`CampaignError` for bad input, before anything is started or written; a campaign
    of more than :data:`LARGE_RUNS` runs, or one estimated to take more than
    :data:`MAX_ESTIMATE_S` (:func:`estimate_wall_s`), is one unless ``large``."""
    t0 = time.monotonic()
    out_dir = Path(out_dir).absolute()
    _check_size(len(spec.seeds), large)
    campaign = plan(spec)
    _check_size(len(campaign.runs), large)
    if spec.engine == "core" and runners.run_fn is None and runners.core_run is None:
        raise CampaignError("engine core: no core run was handed to the engine")
    check_directory(out_dir, campaign, resume)
    _check_estimate(campaign, out_dir, resume, 1 if serial else workers or len(os.sched_getaffinity(0)), large)
    rows = _resumed_rows(out_dir, campaign, resume)
    todo = [t for t in _tasks(campaign, out_dir, spec) if t.run_id not in rows]
    skipped = len(rows)
    client = cluster = None
    if todo and not serial:
        client, cluster = connect(scheduler, workers)
    targets = [s.target for s in spec.sweeps]
    try:
        (out_dir / "runs").mkdir(parents=True, exist_ok=True)
        (out_dir / "campaign.yaml").write_text(yaml.safe_dump(
            {"campaign": spec.to_dict(), "fingerprint": campaign.fingerprint, "runs": len(campaign.runs),
             **({"design": campaign.design} if campaign.design else {})},
            sort_keys=False))
        if todo:
            _execute(todo, runners, client, _Progress(out_dir, rows, len(todo), progress))
            _cleanup(out_dir)
    except KeyboardInterrupt:
        # the finished runs are tabulated and reported; --resume runs the rest
        done = _finished_rows(out_dir, campaign, rows)
        write_results(out_dir, done, targets)
        if done:
            report(out_dir)
        raise KeyboardInterrupt(f"stopped the campaign after {len(done)} of {len(campaign.runs)} runs; their "
                                f"results are in {out_dir / 'results.parquet'} and report/; `--resume --out "
                                f"{out_dir}` runs the rest") from None
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    ordered = [rows[r.run_id] for r in campaign.runs]
    write_results(out_dir, ordered, targets)
    if todo or not _report_is_current(out_dir):
        report(out_dir)
    result = CampaignResult(out_dir, ordered, len(todo), skipped, time.monotonic() - t0)
    with open(out_dir / "invocations.jsonl", "a") as log:  # when, where and how long each call ran
        log.write(json.dumps({"finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "wall_s": result.wall_s,
                              "ran": result.ran, "skipped": skipped, "failed": len(result.failed),
                              "executor": "serial" if serial else (scheduler or f"LocalCluster({workers or 'cores'})"),
                              "engine": spec.engine}) + "\n")
    return result
