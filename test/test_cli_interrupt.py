"""Ctrl-C on ``gimbal-bag play``, ``gimbal-campaign`` and ``gimbal-bench``: each
command, started as a process of its own, gets SIGINT once it is visibly at work (a message
received, a run's result on disk, the graph's sim time in its progress file; never after a
wall-clock sleep), then must exit 130 without a traceback and say what it stopped.
(``gimbal-run`` has its own test: test_run_interrupt.py.)"""
from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from conftest import VENV_BIN
from foreign_bags import synthetic_messages, write_rosbags
from ros_harness import START_TIMEOUT_S, interrupt_when, progress_sim_s

EXIT_INTERRUPTED = 130


def _assert_stopped(code: int, text: str, prog: str) -> None:
    assert code == EXIT_INTERRUPTED, text
    assert "Traceback" not in text, text
    assert f"{prog}: interrupted: " in text, text


@pytest.mark.ros
def test_ctrl_c_on_bag_play_says_how_far_it_played(tmp_path, ros_domain_env):
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Imu

    n_imu = 400  # 2 s of /imu at 200 Hz: 40 s of wall time at --rate 0.05
    bag = write_rosbags(tmp_path / "bag", synthetic_messages(n_imu=n_imu))
    context = Context()
    rclpy.init(context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    received: list[int] = []
    executor = SingleThreadedExecutor(context=context)
    try:
        reader = rclpy.create_node("reader", context=context)
        reader.create_subscription(Imu, "/imu", lambda m: received.append(m.header.stamp.nanosec),
                                   QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        executor.add_node(reader)
        # the player waits for this reader, so it is playing once the reader has a message
        code, text = interrupt_when([str(VENV_BIN / "gimbal-bag"), "play", str(bag), "--topics", "/imu",
                                     "--rate", "0.05", "--wait-for-subscribers", "1", "--wait-timeout", "100"],
                                    ros_domain_env, tmp_path, ready=lambda: bool(received),
                                    wait=lambda: executor.spin_once(timeout_sec=0.05))
    finally:
        executor.shutdown()
        rclpy.shutdown(context=context)
    _assert_stopped(code, text, "gimbal-bag")
    match = re.search(rf"stopped playing {re.escape(str(bag))} after (\d+) of (\d+) messages", text)
    assert match, text
    played, total = int(match[1]), int(match[2])
    assert total == n_imu
    # it was playing, and stopped before the end; a message whose publish call the SIGINT
    # lands in is delivered (we may have it) but not counted, hence the - 1
    assert len(received) - 1 <= played < total


def _results_on_disk(out: Path) -> list[str]:
    return sorted(p.parent.name for p in (out / "runs").glob("*/result.json"))


def test_ctrl_c_on_a_campaign_keeps_its_finished_runs_and_resume_does_the_rest(tmp_path, ros_domain_env):
    seeds = 4  # 10 s simulated by the core engine: about 0.4 s of wall per run here
    out = tmp_path / "campaign"
    cmd = [str(VENV_BIN / "gimbal-campaign"), "sim_open_loop", "--engine", "core", "--serial",
           "--seeds", f"1-{seeds}", "--duration", "10", "--no-progress", "--out", str(out)]
    code, text = interrupt_when(cmd, ros_domain_env, tmp_path, ready=lambda: bool(_results_on_disk(out)))
    _assert_stopped(code, text, "gimbal-campaign")
    done = _results_on_disk(out)
    match = re.search(r"stopped the campaign after (\d+) of (\d+) runs", text)
    assert match, text
    assert (int(match[1]), int(match[2])) == (len(done), seeds)
    assert 1 <= len(done) < seeds
    summary = json.loads((out / "report" / "summary.json").read_text())
    assert (summary["runs"], summary["ok"]) == (len(done), len(done))  # the report counts every run on disk

    resumed = subprocess.run([str(VENV_BIN / "gimbal-campaign"), "--resume", "--out", str(out), "--no-progress"],
                             env=ros_domain_env, capture_output=True, text=True, timeout=START_TIMEOUT_S)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert f"{seeds - len(done)} runs ran, {len(done)} had results, 0 failed" in resumed.stdout, resumed.stdout
    assert len(_results_on_disk(out)) == seeds
    summary = json.loads((out / "report" / "summary.json").read_text())
    assert (summary["runs"], summary["ok"]) == (seeds, seeds)


@pytest.mark.ros
def test_ctrl_c_on_bench_says_which_run_it_stopped(tmp_path, ros_domain_env):
    progress = tmp_path / "progress"  # the orchestrator's sim time: the graph run is under way
    env = dict(ros_domain_env, GIMBAL_RUN_PROGRESS_FILE=str(progress))
    cmd = [str(VENV_BIN / "gimbal-bench"), "run", "--scenario", "sim_open_loop", "--modes", "container",
           "--duration", "7200"]
    code, text = interrupt_when(cmd, env, tmp_path, ready=lambda: progress_sim_s(progress) >= 0.5)
    _assert_stopped(code, text, "gimbal-bench")
    assert "stopped the benchmark in its container run; only --keep keeps its runs" in text, text
    assert "[FATAL]" not in text, text
