"""Campaigns end to end: a real Dask scheduler and workers (one killed mid-campaign), failed
runs recorded, --resume, keep-bags and gimbal-report on a campaign directory.

Every process a test starts is stopped by its PID; graph runs claim their own ROS domain
on this host (``execute_run``) and keep discovery on loopback.
"""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from gimbal_sim.campaign.results import flatten_metrics

BIN = Path(sys.executable).parent


def _campaign(args: list[str], env: dict[str, str], timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / "gimbal-campaign"), *args, "--no-progress"], env=env, capture_output=True,
                          text=True, timeout=timeout)


def _rows(campaign: Path) -> list[dict]:
    return pq.read_table(campaign / "results.parquet").to_pylist()


def _stop(proc: subprocess.Popen) -> None:
    """SIGTERM by PID, SIGKILL if it does not go within 15 s."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _processes_mentioning(text: str) -> list[int]:
    """PIDs whose command line contains ``text`` (Linux /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if text in (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"):
                    pids.append(int(entry.name))
            except OSError:
                pass
    return pids


@pytest.fixture
def dask_cluster(tmp_path, ros_domain_env):
    """``dask scheduler`` and ``dask worker --nworkers 2`` as separate processes on 127.0.0.1."""
    sched_file = tmp_path / "scheduler.json"
    logs = tmp_path / "dask-logs"
    logs.mkdir()
    procs = []
    try:
        with open(logs / "scheduler.log", "w") as log:
            procs.append(subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                           "--no-dashboard", "--scheduler-file", str(sched_file)],
                                          env=ros_domain_env, stdout=log, stderr=subprocess.STDOUT))
        deadline = time.monotonic() + 60
        while not sched_file.is_file() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        with open(logs / "worker.log", "w") as log:
            procs.append(subprocess.Popen([str(BIN / "dask"), "worker", address, "--nworkers", "2", "--nthreads", "1",
                                           "--host", "127.0.0.1", "--no-dashboard",
                                           "--local-directory", str(tmp_path / "dask-worker-space")],
                                          env=ros_domain_env, stdout=log, stderr=subprocess.STDOUT))
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for proc in reversed(procs):
            _stop(proc)


@pytest.mark.slow
@pytest.mark.ros
def test_campaign_on_a_real_scheduler_survives_a_killed_worker_and_matches_serial_runs(
        dask_cluster, tmp_path, ros_domain_env):
    """One seed in both variants, a run per worker: the killed worker's run is done again
    and every metric equals gimbal-run's. Seed 2 is not the scenario's own (1), so that
    equality also shows the campaign's seed reached the run; campaigns of several seeds are
    the other tests' concern."""
    from distributed import Client

    out = tmp_path / "campaign"
    cmd = [str(BIN / "gimbal-campaign"), "sighting_land_vehicle", "--seeds", "2", "--duration", "3",
           "--mode", "container", "--scheduler", dask_cluster, "--out", str(out), "--no-progress"]
    campaign = subprocess.Popen(cmd, env=ros_domain_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    killed = None
    try:
        with Client(dask_cluster, timeout="30s") as client:
            pids = client.run(os.getpid)  # worker address -> its process id
            seen: dict[tuple[str, str], float] = {}
            deadline = time.monotonic() + 300
            while killed is None and campaign.poll() is None and time.monotonic() < deadline:
                now = time.monotonic()
                for worker, keys in client.processing().items():
                    for key in keys:
                        if now - seen.setdefault((worker, key), now) > 2.0:  # a run well under way
                            os.kill(pids[worker], signal.SIGKILL)
                            killed = (worker, key, pids[worker])
                            break
                    if killed:
                        break
                time.sleep(0.2)
        output, _ = campaign.communicate(timeout=600)
    finally:
        _stop(campaign)
    assert killed is not None, "no run was seen in progress to kill its worker"
    assert campaign.returncode == 0, output
    rows = _rows(out)
    assert len(rows) == 2 and all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]
    killed_run = killed[1].rsplit("-", 1)[1]
    assert killed_run in {r["run_id"] for r in rows}  # the killed worker's run was done again, elsewhere
    assert not (out / "runs" / ".attempts").exists()  # its half-done attempt was cleaned away
    deadline = time.monotonic() + 30  # the killed worker's gimbal-run went with it (PR_SET_PDEATHSIG)
    while _processes_mentioning(str(out / "runs" / ".attempts")) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not _processes_mentioning(str(out / "runs" / ".attempts"))

    # the same runs, serially, by gimbal-run itself: every metric of every run is the same
    for seed in (2,):
        serial = tmp_path / f"serial{seed}"
        result = subprocess.run([str(BIN / "gimbal-run"), "sighting_land_vehicle", "--seed", str(seed),
                                 "--duration", "3", "--mode", "container", "--out", str(serial), "--no-progress"],
                                env=ros_domain_env, capture_output=True, text=True, timeout=600)
        assert result.returncode == 0, result.stderr[-3000:]
        for variant in ("ekf_off", "ekf_on"):
            (row,) = [r for r in rows if r["seed"] == seed and r["variant"] == variant]
            ours = flatten_metrics(json.loads((out / "runs" / row["run_id"] / "report" / "metrics.json").read_text()))
            theirs = flatten_metrics(json.loads((serial / variant / "report" / "metrics.json").read_text()))
            assert ours.keys() == theirs.keys()
            differ = {k: (ours[k], theirs[k]) for k in ours if json.dumps(ours[k]) != json.dumps(theirs[k])}
            assert not differ, f"seed {seed} {variant}: {differ}"
            assert row["sighting.final_drift_deg.azimuth"] == theirs["sighting.final_drift_deg.azimuth"]


def test_core_campaign_records_failures_carries_on_and_resumes(tmp_path, ros_domain_env):
    out = tmp_path / "campaign"
    args = ["sighting_land_vehicle", "--variant", "ekf_on", "--seeds", "1-2", "--duration", "1", "--engine", "core",
            "--sweep", "los_rate_controller.omega_n_hz=25,300", "--serial", "--out", str(out)]
    first = _campaign(args, ros_domain_env)
    assert first.returncode == 1, first.stdout + first.stderr
    rows = {(r["seed"], r["sweep.los_rate_controller.omega_n_hz"]): r for r in _rows(out)}
    assert len(rows) == 4
    for seed in (1, 2):
        assert rows[(seed, 25)]["status"] == "ok"
        failed = rows[(seed, 300)]
        # ω_n = 300 Hz passes the parameter's range but not the core's rate_hz / 4 check, which
        # the core loop meets only when it builds the stage: the run fails, named, with its traceback tail
        assert failed["status"] == "failed" and "omega_n_hz must be < rate_hz / 4" in failed["reason"]
        assert "Traceback" in failed["log_tail"]
    assert "FAILED" in first.stdout

    again = _campaign([*args, "--resume"], ros_domain_env)
    assert again.returncode == 1
    assert "2 runs ran, 2 had results, 2 failed" in again.stdout  # only the failed ones ran again
    assert len(list((out / "runs").glob("*.failed-*"))) == 2      # the earlier failures kept beside

    # a finished campaign: --resume runs nothing and does not even start or reach a cluster
    # (this scheduler address answers nobody; connecting would be refused with exit 2)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        nowhere = f"tcp://127.0.0.1:{s.getsockname()[1]}"
        only_ok = [a.replace("=25,300", "=25") for a in args if a != "--serial"]
        done = _campaign([*only_ok, "--resume", "--scheduler", nowhere], ros_domain_env)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 runs ran, 2 had results, 0 failed" in done.stdout
    assert [r["status"] for r in _rows(out)] == ["ok", "ok"]
    with open(out / "invocations.jsonl") as f:
        calls = [json.loads(line) for line in f]
    assert [c["ran"] for c in calls] == [4, 2, 0]


@pytest.mark.ros
def test_graph_campaign_keeps_what_it_is_told_and_gimbal_report_regenerates_from_bags(tmp_path, ros_domain_env):
    out = tmp_path / "campaign"
    # What is kept and what the report recomputes from a bag do not depend on the run's length:
    # 1 s runs record every topic and give every figure (the ones scored after 30 s are NaN at any length under 30 s)
    base = ["sighting_land_vehicle", "--variant", "ekf_on", "--duration", "1", "--serial"]
    result = _campaign([*base, "--seeds", "1-2", "--out", str(out)], ros_domain_env)
    assert result.returncode == 0, result.stdout + result.stderr
    before = _rows(out)
    runs = [out / "runs" / r["run_id"] for r in before]
    assert all((run / f"{run.name}_0.mcap").is_file() and (run / "params").is_dir() for run in runs)
    # spoil one run's figures: gimbal-report CAMPAIGN_DIR recomputes them from its bag
    metrics_file = runs[0] / "report" / "metrics.json"
    metrics = json.loads(metrics_file.read_text())
    metrics["sighting"]["final_drift_deg"]["azimuth"] = 123.0
    metrics_file.write_text(json.dumps(metrics))
    regen = subprocess.run([str(BIN / "gimbal-report"), str(out)], env=ros_domain_env, capture_output=True,
                           text=True, timeout=600)
    assert regen.returncode == 0, regen.stderr
    assert json.dumps(_rows(out)) == json.dumps(before)  # NaN-aware: NaN figures of a short run stay NaN
    assert (out / "report" / "summary.md").is_file() and list((out / "report").glob("hist_*.png"))

    none = tmp_path / "no_bags"
    result = _campaign([*base, "--seeds", "3", "--keep-bags", "none", "--out", str(none)], ros_domain_env)
    assert result.returncode == 0, result.stdout + result.stderr
    (row,) = _rows(none)
    run = none / "runs" / row["run_id"]
    assert not list(run.glob("*.mcap")) and (run / "report" / "metrics.json").is_file()
    assert row["sighting.final_drift_deg.azimuth"] is not None

    slow = tmp_path / "timeout"
    result = _campaign([*base, "--seeds", "4", "--duration", "30", "--timeout", "3", "--keep-bags", "failed",
                        "--out", str(slow)], ros_domain_env)
    assert result.returncode == 1
    (row,) = _rows(slow)
    assert row["status"] == "failed" and row["reason"] == "timed out after 3 s"
    assert (slow / "runs" / row["run_id"] / "logs" / "gimbal-run.log").is_file()


def _seeded_mean_run(task, run_dir: Path) -> None:
    """A caller's own run (the hook the experiment runners plug into): a seeded sample mean
    scaled by the swept value, written as the run's metrics."""
    import numpy as np

    gain = task.values["los_rate_controller.omega_n_hz"]
    value = gain * float(np.random.default_rng(task.seed).normal(size=1000).mean())
    (run_dir / "report").mkdir()
    (run_dir / "report" / "metrics.json").write_text(json.dumps({"experiment": {"scaled_mean": value}}))


def test_run_campaign_api_runs_a_callable_per_run(tmp_path):
    import numpy as np

    from gimbal_sim.experiments.registry import run_campaign
    from gimbal_sim.campaign.spec import spec_from_mapping

    spec = spec_from_mapping({"scenario": "sighting_land_vehicle", "variants": ["ekf_on"], "seeds": "1-4",
                              "sweep": {"los_rate_controller.omega_n_hz": "10,20"}})
    result = run_campaign(spec, tmp_path / "c", serial=True, progress=False, run_fn=_seeded_mean_run)
    assert result.ran == 8 and not result.failed
    rows = _rows(tmp_path / "c")
    for row in rows:
        expected = row["sweep.los_rate_controller.omega_n_hz"] * np.random.default_rng(row["seed"]).normal(
            size=1000).mean()
        assert row["experiment.scaled_mean"] == expected and row["engine"] == "custom"
    summary = json.loads((tmp_path / "c" / "report" / "summary.json").read_text())
    for group in summary["groups"]:
        gain = group["sweep"]["los_rate_controller.omega_n_hz"]
        values = [gain * np.random.default_rng(s).normal(size=1000).mean() for s in range(1, 5)]
        assert group["metrics"]["experiment.scaled_mean"]["mean"] == pytest.approx(np.mean(values), rel=1e-12)


def _interrupted_at_seed_3(task, run_dir: Path) -> None:
    if task.seed == 3:
        raise KeyboardInterrupt  # as Ctrl-C would, mid-campaign
    _seeded_mean_run(task, run_dir)


def test_an_interrupted_campaign_keeps_its_finished_runs_and_resume_completes_it(tmp_path):
    from gimbal_sim.experiments.registry import run_campaign
    from gimbal_sim.campaign.spec import spec_from_mapping

    spec = spec_from_mapping({"scenario": "sighting_land_vehicle", "seeds": "1-4",
                              "sweep": {"los_rate_controller.omega_n_hz": "10"}})
    with pytest.raises(KeyboardInterrupt):
        run_campaign(spec, tmp_path / "c", serial=True, progress=False, run_fn=_interrupted_at_seed_3)
    # seed by seed, both variants of a seed together: seeds 1 and 2 finished, in both variants
    assert sorted((r["seed"], r["variant"]) for r in _rows(tmp_path / "c")) == \
        [(1, "ekf_off"), (1, "ekf_on"), (2, "ekf_off"), (2, "ekf_on")]
    assert (tmp_path / "c" / "report" / "summary.json").is_file()
    result = run_campaign(spec, tmp_path / "c", resume=True, serial=True, progress=False, run_fn=_seeded_mean_run)
    assert (result.ran, result.skipped, len(result.failed)) == (4, 4, 0)
    assert [(r["seed"], r["variant"]) for r in _rows(tmp_path / "c")] == \
        [(s, v) for s in (1, 2, 3, 4) for v in ("ekf_off", "ekf_on")]
    assert not (tmp_path / "c" / "runs" / ".attempts").exists()
