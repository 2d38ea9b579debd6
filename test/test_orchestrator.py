"""gimbal-run: a recorded run read back by rosbags and mcap, equal to what the cores
publish; both modes record the same data; bad input and dying nodes are handled."""
from __future__ import annotations

import os
import signal
import subprocess
import time
from collections import defaultdict
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN
from gimbal_sim.bag.reader import read_messages, scan
from gimbal_sim.nodes.sensor_models_node import truth_from_group
from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore
from gimbal_kinematics.ros import messages as m

pytestmark = pytest.mark.ros
#: A 2 s open-loop run: 2001 lockstep steps of every 1 kHz topic, each message counted and
#: checked against the cores, in both modes; the counts and values do not depend on the length.
DURATION_S, RATE = 2.0, 1000.0
STEPS = int(DURATION_S * RATE)


def gimbal_run(env, *args, timeout=300):
    return subprocess.run([str(VENV_BIN / "gimbal-run"), *args, "--no-progress"], env=env, capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture(scope="module")
def recorded(module_ros_domain_env, tmp_path_factory) -> dict[str, Path]:
    """The same short open-loop scenario run once in each mode."""
    runs = {}
    for mode in ("processes", "container"):
        out = tmp_path_factory.mktemp(mode) / "run"
        result = gimbal_run(module_ros_domain_env, "sim_open_loop", "--duration", str(DURATION_S), "--out", str(out),
                            "--mode", mode)
        assert result.returncode == 0, result.stdout + result.stderr
        runs[mode] = out
    return runs


def test_bag_opens_with_rosbags_and_mcap_with_every_message(recorded):
    out = recorded["processes"]
    expected_counts = {t: STEPS + 1 for t in ("/clock", "/truth/host/imu", "/truth/host/delta_angle",
                                              "/truth/gimbal/imu", "/truth/gimbal/joint_states", "/gimbal/imu",
                                              "/gimbal/joint_states", "/truth/gimbal/gyro_bias")}
    expected_counts |= {"/ins/imu": STEPS // 10 + 1, "/truth/ins/gyro_bias": STEPS // 10 + 1,
                        "/sensor_models/progress": STEPS // 10 + 1}
    with AnyReader([out]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == expected_counts
        decoded = defaultdict(list)
        for connection, t, raw in reader.messages():
            decoded[connection.topic].append((t, reader.deserialize(raw, connection.msgtype)))
    with open(next(out.glob("*.mcap")), "rb") as f:
        mcap_counts = defaultdict(int)
        for _, channel, _, _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            mcap_counts[channel.topic] += 1
    assert dict(mcap_counts) == expected_counts

    # what the publishers sent: the cores driven the same way, through the same message edge
    core = VehicleCore(VehicleConfig(sim_rate_hz=RATE, duration_s=DURATION_S))
    suite = SensorSuite(SensorSuiteConfig(sim_rate_hz=RATE, seed=0))
    gyro, joints = [], []
    for k in range(STEPS + 1):
        truth = core.truth()
        t_ns = m.step_stamp_ns(k, RATE)
        group = {"/truth/host/imu": m.imu_msg(t_ns, "base_link_frd", orientation=truth.quat_nb,
                                              angular_velocity=truth.omega_ib_b,
                                              linear_acceleration=truth.specific_force_b),
                 "/truth/gimbal/imu": m.imu_msg(t_ns, "x", orientation=truth.quat_nm,
                                                angular_velocity=truth.omega_im_m),
                 "/truth/gimbal/joint_states": m.joint_state_msg(t_ns, truth.joint_names, truth.joint_position,
                                                                 truth.joint_velocity)}
        joints.append(truth.joint_position)
        gyro += [(s.q_m, s.r_m) for s in suite.update(truth_from_group(k, k / RATE, group)) if hasattr(s, "q_m")]
        if k < STEPS:
            core.step((0.0, 0.0))
    assert [tuple(msg.position) for _, msg in decoded["/truth/gimbal/joint_states"]] == joints
    assert [(msg.angular_velocity.y, msg.angular_velocity.z) for _, msg in decoded["/gimbal/imu"]] == gyro
    assert [t for t, _ in decoded["/clock"]] == [m.step_stamp_ns(k, RATE) for k in range(STEPS + 1)]
    assert (out / "report" / "metrics.json").is_file() and list((out / "report").glob("*.png"))


def test_both_modes_record_the_same_data(recorded):
    def by_topic(out):
        messages, contents = read_messages(out)
        assert contents.closed_cleanly
        topics = defaultdict(list)
        for x in messages:
            topics[x.topic].append((x.log_time_ns, x.data))
        return topics

    processes, container = by_topic(recorded["processes"]), by_topic(recorded["container"])
    assert processes.keys() == container.keys()
    for topic in processes:
        assert processes[topic] == container[topic], topic


def test_report_regenerates_from_the_bag(recorded, tmp_path):
    result = subprocess.run([str(VENV_BIN / "gimbal-report"), str(recorded["container"])], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "report written" in result.stdout


@pytest.mark.parametrize("args,named", [
    (["no_such_scenario"], "unknown scenario"),
    (["sim_open_loop", "--set", "vehicle_dynamics"], "expected node.param=value"),
    (["sim_open_loop", "--set", "nobody.x=1"], "no node 'nobody'"),
    (["sim_open_loop", "--set", "vehicle_dynamics.warp_factor=9"], "no parameter 'warp_factor'"),
    (["sim_open_loop", "--set", "vehicle_dynamics.sim_rate_hz=fast"], "sim_rate_hz"),
    (["sim_open_loop", "--duration", "-1"], "--duration"),
])
def test_bad_input_exits_2_before_starting(args, named, ros_domain_env, tmp_path):
    result = gimbal_run(ros_domain_env, *args, "--out", str(tmp_path / "run"))
    assert result.returncode == 2, result.stderr
    assert named in result.stderr
    assert not (tmp_path / "run").exists()


def test_existing_output_and_bad_scenario_files_are_refused(ros_domain_env, tmp_path):
    (tmp_path / "run").mkdir()
    keep = tmp_path / "run" / "precious.txt"
    keep.write_text("keep me")
    result = gimbal_run(ros_domain_env, "sim_open_loop", "--out", str(tmp_path / "run"))
    assert result.returncode == 2 and "already exists" in result.stderr
    assert keep.read_text() == "keep me" and len(list((tmp_path / "run").iterdir())) == 1
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nduration_s: 1\nnodes:\n  warp_drive: {}\n")
    result = gimbal_run(ros_domain_env, str(bad), "--out", str(tmp_path / "run2"))
    assert result.returncode == 2 and "unknown executable 'warp_drive'" in result.stderr
    bad.write_text("name: x\nnodes: [unclosed\n")
    result = gimbal_run(ros_domain_env, str(bad), "--out", str(tmp_path / "run2"))
    assert result.returncode == 2 and "not valid YAML" in result.stderr
    for args in (["info", str(keep)], ["info", str(tmp_path / "nothing")], ["recover", str(tmp_path)]):
        result = subprocess.run([str(VENV_BIN / "gimbal-bag"), *args], capture_output=True, text=True, timeout=60)
        assert result.returncode == 2, (args, result.stderr)
    result = subprocess.run([str(VENV_BIN / "gimbal-report"), str(tmp_path)], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 2 and "not a bag" in result.stderr


def _child_pid(parent: int, executable: str) -> int | None:
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            stat = (proc / "stat").read_text()
            cmdline = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        if ppid == parent and any(arg.endswith(executable.encode()) for arg in cmdline[:2]):
            return int(proc.name)
    return None


def test_a_dying_node_ends_the_run_named_and_the_bag_is_kept(ros_domain_env, tmp_path):
    out = tmp_path / "run"
    # The run writes its sim time to this file as it steps: the victim is killed once the
    # graph has stepped (and the recorder recorded) at least 0.5 s, whatever the machine's speed.
    progress = tmp_path / "progress"
    env = dict(ros_domain_env, GIMBAL_RUN_PROGRESS_FILE=str(progress))
    run = subprocess.Popen([str(VENV_BIN / "gimbal-run"), "sim_open_loop", "--duration", "600", "--out", str(out),
                            "--no-progress"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)

    def sim_time() -> float:
        try:
            return float(progress.read_text() or 0.0)
        except (FileNotFoundError, ValueError):  # not written yet, or caught mid-write
            return 0.0

    try:
        deadline = time.monotonic() + 120
        victim = None
        while victim is None or sim_time() < 0.5:
            assert time.monotonic() < deadline and run.poll() is None, "the run did not start stepping"
            victim = victim or _child_pid(run.pid, "sensor_models")
            time.sleep(0.05)
        os.kill(victim, signal.SIGKILL)
        killed = time.monotonic()
        _, stderr = run.communicate(timeout=60)
        stopped_after = time.monotonic() - killed
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 1
    assert "node 'sensor_models' exited with code -9" in stderr and "last log lines" in stderr
    assert stopped_after < 20.0  # detection takes < 0.1 s; the rest is the other nodes' clean shutdown
    contents = scan(out)
    assert contents.closed_cleanly and contents.topics["/clock"].count > 100
    with AnyReader([out]) as reader:
        assert reader.message_count == contents.message_count
    assert all(_child_pid(run.pid, exe) is None for exe in ("vehicle_dynamics", "bag_recorder"))
