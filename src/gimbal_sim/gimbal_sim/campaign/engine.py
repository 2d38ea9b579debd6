"""The campaign engine: every run of a campaign as one Dask task, results in one table.

``run_campaign(spec, out_dir)`` plans the runs (:mod:`.campaign_spec`), submits the ones
without results to a Dask cluster (an embedded ``LocalCluster`` on 127.0.0.1 sized to the
cores, or ``scheduler="tcp://host:port"``), and writes the campaign directory::

    OUT/campaign.yaml        what was asked, and the fingerprint a --resume must match
    OUT/runs/<run_id>/       one run: bag, params/, logs/, scenario.yaml, run.json,
                             report/metrics.json, and result.json (the run's row)
    OUT/results.parquet      one row per run (also results.csv): run id, variant, seed,
                             swept values (sweep.<node.param>), status, reason, wall time,
                             every numeric metric of the run's report (dotted paths)
    OUT/report/              the campaign report (:mod:`.campaign_report`)

A task (:func:`execute_run`) runs on whichever worker gets it. Engine ``graph`` runs the
real node graph as a child ``gimbal-run`` of the single-run scenario, in a ROS domain
claimed on that host with discovery kept on it; engine ``core`` steps the same cores in
the worker (:mod:`.core_metrics`); a caller's own ``run_fn(task, run_dir) -> metrics``
replaces both (the hook for the experiment runners). Each attempt writes into a fresh
``runs/.attempts/<id>-<token>/<id>/`` and is renamed to ``runs/<id>/`` only when complete, so a
task Dask reschedules after its worker died starts clean, and a half-done attempt never
looks like a result. A run that fails (a node died, a timeout, bad metrics) gets a row
with its reason and log tail; the campaign carries on.
"""
from __future__ import annotations

import csv
import ctypes
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import yaml

from .spec import CampaignError, CampaignPlan, CampaignSpec, plan

RESULT_FILE = "result.json"
CONNECT_TIMEOUT_S = 5.0           # an unreachable scheduler is refused within this
STOP_GRACE_S = 20.0               # a timed-out gimbal-run gets this long to close its bag after SIGINT
LOG_TAIL_LINES = 25
#: Columns every row has, in this order; swept values follow as sweep.<target>, then the metrics.
FIXED_COLUMNS = ("run_id", "scenario", "variant", "seed", "engine", "status", "reason", "wall_s", "host", "log_tail")
#: Entries of a report's metrics.json that are not figures (paths, plot lists, per-topic counts, text).
NOT_METRICS = {"plots", "topics", "bag", "read_error", "report", "runs", "table", "comparison"}
_SCHEDULER = re.compile(r"^(tcp|tls)://[^\s/:]+:\d{1,5}$")


@dataclass(frozen=True)
class RunTask:
    """One run, as shipped to a worker (picklable): the single-run scenario as YAML and how
    to run it. ``values`` are the swept values (target -> value)."""

    run_id: str
    campaign_dir: str
    scenario_yaml: str
    scenario_name: str
    variant: str
    seed: int
    values: dict[str, Any]
    engine: str
    mode: str
    compress: bool
    keep_bags: str
    timeout_s: float
    experiment: str = ""                  # an experiment runner's campaign (its name is scenario_name)
    options: dict[str, Any] = field(default_factory=dict)   # the runner's settings


#: A caller's run: (task, run_dir to create) -> the run's metrics (a metrics.json mapping).
RunFunction = Callable[[RunTask, Path], dict]


@dataclass
class CampaignResult:
    directory: Path
    rows: list[dict[str, Any]]        # one per planned run, in plan order
    ran: int                          # runs executed by this call
    skipped: int                      # runs whose results already existed (--resume)
    wall_s: float

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]


# ------------------------------------------------------------------ the task (worker side)
def flatten_metrics(metrics: dict[str, Any], prefix: str = "") -> dict[str, float | None]:
    """Numeric leaves of a metrics.json mapping by dotted path (list items as ``path.i``);
    booleans as 0/1; text, plot lists and per-topic counts left out."""
    out: dict[str, float | None] = {}
    for key, value in metrics.items():
        if not prefix and key in NOT_METRICS:
            continue
        path = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten_metrics(value, path + "."))
        elif isinstance(value, list):
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                out.update({f"{path}.{i}": float(v) for i, v in enumerate(value)})
        elif isinstance(value, bool):
            out[path] = float(value)
        elif isinstance(value, (int, float)):
            out[path] = float(value)
        elif value is None:
            out[path] = None
    return out


def _die_with_parent() -> None:
    """In the child, before exec: SIGINT when the worker that started it dies (Linux
    PR_SET_PDEATHSIG), so a killed worker leaves no run going on that nobody waits for."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGINT)
    except OSError:
        pass


def _tail(text: str, lines: int = LOG_TAIL_LINES) -> str:
    return "\n".join(text.splitlines()[-lines:])


def _run_graph(task: RunTask, attempt: Path) -> tuple[str, str]:
    """``gimbal-run`` of the task's scenario into ``attempt``; returns (failure reason or "",
    log tail). The child gets a ROS domain claimed on this host; its lock is passed to the
    child so that the id stays taken for as long as the child lives."""
    from gimbal_kinematics.ros.ros_domain import claim_domain_id

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
                                    preexec_fn=_die_with_parent, pass_fds=(lock_fd,))
        try:
            code = proc.wait(timeout=task.timeout_s)
            if code != 0:
                reason = f"gimbal-run exited with code {code}"
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)  # by PID: it closes its bag and stops its nodes
            try:
                proc.wait(timeout=STOP_GRACE_S)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            reason = f"timed out after {task.timeout_s:g} s"
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
    if engine == "graph" and not metrics.get("closed_cleanly", False):
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


def execute_run(task: RunTask, run_fn: RunFunction | None = None) -> dict[str, Any]:
    """Run one task where it lands (a Dask worker, or this process) and return its row.

    Never raises for a failed run: the row says ``status: failed`` with the reason and the
    log tail. Writes ``runs/<id>/`` (via an attempt directory renamed when complete)."""
    from ..graph.scenario import validate

    runs = Path(task.campaign_dir) / "runs"
    final = runs / task.run_id
    if (final / RESULT_FILE).is_file():  # an earlier attempt of this task completed it
        return json.loads((final / RESULT_FILE).read_text())
    # named like the run, so that the bag inside is <id>_0.mcap; its parent is the attempt's own
    attempt = runs / ".attempts" / f"{task.run_id}-{uuid.uuid4().hex[:8]}" / task.run_id
    attempt.parent.mkdir(parents=True)
    t0 = time.monotonic()
    reason, log_tail, metrics = "", "", None
    try:
        if run_fn is not None:
            attempt.mkdir(parents=True)
            run_fn(task, attempt)
        elif task.engine == "graph":
            reason, log_tail = _run_graph(task, attempt)
        else:
            from ..reports.core_metrics import run_core

            run_core(validate(yaml.safe_load(task.scenario_yaml), task.scenario_name), attempt)
        # only a graph run has a bag to check; an experiment's run function is its core engine
        engine = "custom" if run_fn is not None and not task.experiment else task.engine
        metrics, why = _check_metrics(attempt, engine) if not reason or attempt.exists() else (None, "")
        reason = reason or why
    except Exception as exc:  # noqa: BLE001 - any failure of one run is recorded, the campaign goes on
        reason = f"{type(exc).__name__}: {exc}"
        log_tail = _tail(traceback.format_exc())
    attempt.mkdir(parents=True, exist_ok=True)
    engine_label = "custom" if run_fn is not None and not task.experiment else task.engine
    status = "failed" if reason else "ok"
    bag_kept = any(attempt.glob("*.mcap"))
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


def _run_dask(client: Any, todo: list[RunTask], run_fn: RunFunction | None, on_row, show) -> None:
    """Submit every task (in plan order), hand each finished one's row to ``on_row``, and
    ``show(running)`` the number of our tasks the workers are processing every 5 s."""
    nonce = uuid.uuid4().hex[:8]
    futures = {client.submit(execute_run, task, run_fn, key=f"gimbal-campaign-{nonce}-{task.run_id}",
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


def run_campaign(spec: CampaignSpec, out_dir: Path, *, resume: bool = False, scheduler: str | None = None,
                 workers: int | None = None, serial: bool = False, progress: bool = True,
                 run_fn: RunFunction | None = None) -> CampaignResult:
    """Run the campaign ``spec`` into ``out_dir`` (module docstring). ``serial`` runs the
    tasks one by one in this process (no Dask); ``run_fn`` replaces the engine's run.
    Raises :class:`CampaignError` for bad input, before anything is started or written."""
    t0 = time.monotonic()
    out_dir = Path(out_dir).absolute()
    campaign = plan(spec)
    if spec.experiment and spec.engine == "core" and run_fn is None:
        from .experiment import run_experiment_task

        run_fn = run_experiment_task
    check_directory(out_dir, campaign, resume)
    rows: dict[str, dict[str, Any]] = {}
    for run in campaign.runs:
        row = _load_row(out_dir, run.run_id) if resume else None
        if row is not None and row.get("status") == "ok":
            rows[run.run_id] = row
        elif row is not None:  # an earlier failure: kept beside, then run again
            stamp = time.strftime("%Y%m%d-%H%M%S")
            (out_dir / "runs" / run.run_id).rename(out_dir / "runs" / f"{run.run_id}.failed-{stamp}")
    todo = [t for t in _tasks(campaign, out_dir, spec) if t.run_id not in rows]
    skipped = len(rows)
    client = cluster = None
    if todo and not serial:
        client, cluster = connect(scheduler, workers)
    try:
        (out_dir / "runs").mkdir(parents=True, exist_ok=True)
        (out_dir / "campaign.yaml").write_text(yaml.safe_dump(
            {"campaign": spec.to_dict(), "fingerprint": campaign.fingerprint, "runs": len(campaign.runs)},
            sort_keys=False))
        if todo:
            bar = _progress(len(todo), progress)
            failed, running = 0, 0

            def show(now_running: int | None = None) -> None:
                nonlocal running
                running = running if now_running is None else now_running
                bar.set_postfix_str(f"failed {failed}, running {running}", refresh=True)

            def on_row(row: dict[str, Any]) -> None:
                nonlocal failed
                rows[row["run_id"]] = row
                path = out_dir / "runs" / row["run_id"] / RESULT_FILE
                if not path.is_file():  # the worker's disk is not ours: keep the row here
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_text(json.dumps(row, indent=1, default=float) + "\n")
                if row["status"] != "ok":
                    failed += 1
                    bar.write(f"run {row['run_id']} ({row['variant'] or '-'}, seed {row['seed']}) failed: "
                              f"{row['reason']}", file=sys.stderr)
                bar.update(1)
                show()

            try:
                if serial:
                    for task in todo:
                        show(1)
                        try:
                            row = execute_run(task, run_fn)
                        except OSError as exc:  # its attempt could not be put in place: kept, named
                            row = failed_row(task, f"{type(exc).__name__}: {exc}")
                        on_row(row)
                else:
                    _run_dask(client, todo, run_fn, on_row, show)
            finally:
                bar.close()
            _cleanup(out_dir)
    except KeyboardInterrupt:
        # the finished runs are tabulated and reported; --resume runs the rest
        done = [rows[r.run_id] for r in campaign.runs if r.run_id in rows]
        write_results(out_dir, done, [s.target for s in spec.sweeps])
        if done:
            from .report import write_campaign_report

            write_campaign_report(out_dir)
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    ordered = [rows[r.run_id] for r in campaign.runs]
    write_results(out_dir, ordered, [s.target for s in spec.sweeps])
    if todo or not (out_dir / "report").is_dir():
        from .report import write_campaign_report

        write_campaign_report(out_dir)
    result = CampaignResult(out_dir, ordered, len(todo), skipped, time.monotonic() - t0)
    with open(out_dir / "invocations.jsonl", "a") as log:  # when, where and how long each call ran
        log.write(json.dumps({"finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "wall_s": result.wall_s,
                              "ran": result.ran, "skipped": skipped, "failed": len(result.failed),
                              "executor": "serial" if serial else (scheduler or f"LocalCluster({workers or 'cores'})"),
                              "engine": spec.engine}) + "\n")
    return result


# ------------------------------------------------------------------ the results table
def table_rows(rows: list[dict[str, Any]], sweep_targets: list[str]) -> tuple[list[str], list[dict[str, Any]]]:
    """(columns, flat rows) of the results table: fixed columns, sweep.<target>, metrics."""
    metric_cols: dict[str, None] = {}
    for row in rows:
        metric_cols.update(dict.fromkeys(row.get("metrics", {})))
    columns = list(FIXED_COLUMNS) + [f"sweep.{t}" for t in sweep_targets] + list(metric_cols)
    flat = []
    for row in rows:
        item = {c: row.get(c) for c in FIXED_COLUMNS}
        item.update({f"sweep.{t}": row.get("values", {}).get(t) for t in sweep_targets})
        item.update({c: row.get("metrics", {}).get(c) for c in metric_cols})
        flat.append(item)
    return columns, flat


def write_results(out_dir: Path, rows: list[dict[str, Any]], sweep_targets: list[str]) -> Path:
    """``results.parquet`` (and ``results.csv``) of the rows; returns the Parquet path."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns, flat = table_rows(rows, sweep_targets)
    arrays = {}
    for col in columns:
        values = [r[col] for r in flat]
        if col in ("seed",):
            arrays[col] = pa.array(values, pa.int64())
        elif col in FIXED_COLUMNS and col != "wall_s":
            arrays[col] = pa.array(["" if v is None else str(v) for v in values], pa.string())
        elif col.startswith("sweep."):
            arrays[col] = pa.array(values)  # the parameter's own type (number, bool, text)
        else:
            arrays[col] = pa.array([None if v is None else float(v) for v in values], pa.float64())
    path = out_dir / "results.parquet"
    tmp = path.with_suffix(".parquet.tmp")
    pq.write_table(pa.table(arrays), tmp)
    tmp.replace(path)
    with open(out_dir / "results.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(flat)
    return path


def read_results(out_dir: Path) -> list[dict[str, Any]]:
    """The rows of ``results.parquet`` (pyarrow), as dicts by column."""
    import pyarrow.parquet as pq

    return pq.read_table(Path(out_dir) / "results.parquet").to_pylist()
