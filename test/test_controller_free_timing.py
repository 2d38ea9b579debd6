"""``los_rate_controller`` in free timing against a stand-in driver process (plain rclpy,
standard messages, wall-clock stamps with jitter): one command per gyro sample, stamped like
it, at the gyro's rate; when the encoders stop, the command is zeroed and every such
command is counted on /diagnostics."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState

from gimbal_kinematics.ros import messages as m
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros
DRIVER = Path(__file__).with_name("controller_driver.py")
GYRO_HZ, MAX_AGE_S, STOP_S, DURATION_S = 200.0, 0.1, 2.5, 4.0


@pytest.mark.parametrize("qos", ["sensor_data", "default"])
def test_one_command_per_gyro_sample_and_zeroed_counted_when_the_encoders_stop(ros_domain_env, tmp_path, qos):
    controller = {"sim_rate_hz": GYRO_HZ, "ins_rate_hz": 50.0, "max_input_age_s": MAX_AGE_S,
                  "diagnostics_period_s": 0.1}
    # rclpy's standard QoS overrides: a deeper input queue, so that a test process descheduled on
    # a loaded machine for a few periods does not lose best-effort samples (depth 5 by default)
    for topic in ("/gimbal/imu", "/gimbal/joint_states", "/ins/imu"):
        controller[f"qos_overrides.{topic}.subscription.depth"] = 1000
    commands: dict[int, tuple[float, float]] = {}
    diagnostics: list[tuple[int, dict[str, str]]] = []

    def on_cmd(msg: JointState) -> None:
        stamp = m.stamp_ns(msg.header.stamp)
        assert stamp not in commands, "two commands for one gyro sample"
        commands[stamp] = tuple(msg.effort)

    def on_diag(msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.hardware_id == "los_rate_controller":
                diagnostics.append((m.stamp_ns(msg.header.stamp), {kv.key: kv.value for kv in status.values}))

    out = tmp_path / "published.json"
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        subs = [node.create_subscription(JointState, "/gimbal/torque_cmd", on_cmd, QoSProfile(depth=1000)),
                node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, QoSProfile(depth=100))]
        with node_processes([("los_rate_controller", controller)], ros_domain_env, tmp_path):
            # the controller's outputs reach us before the driver starts (its publishers are volatile)
            assert spin_until(executor, lambda: all(s.get_publisher_count() for s in subs), timeout_s=30.0)
            driver = subprocess.Popen([sys.executable, str(DRIVER), "--qos", qos, "--duration-s", str(DURATION_S),
                                       "--encoders-stop-s", str(STOP_S), "--gyro-hz", str(GYRO_HZ),
                                       "--jitter", "0.2", "--out", str(out)], env=ros_domain_env)
            try:
                assert spin_until(executor, lambda: driver.poll() is not None, timeout_s=90.0)
                spin_until(executor, lambda: False, timeout_s=0.5)  # the last commands in flight
            finally:
                if driver.poll() is None:
                    driver.kill()
                driver.wait()
    assert driver.returncode == 0
    published = json.loads(out.read_text())
    gyro, enc = published["gyro"], published["enc"]
    stamps = sorted(commands)
    # every command answers a gyro sample, stamped like it; best effort may lose a sample in transit
    assert set(stamps) <= set(gyro)
    assert len(stamps) >= 0.98 * len(gyro), (len(stamps), len(gyro), diagnostics[-1])
    # at the gyro's rate: the commands' median interval is the gyro's period
    assert np.median(np.diff(stamps)) == pytest.approx(1e9 / GYRO_HZ, rel=0.05)
    stale_from = enc[-1] + int(MAX_AGE_S * 1e9)
    zeroed = [t for t in stamps if commands[t] == (0.0, 0.0)]
    after_stop = [t for t in stamps if t > stale_from]
    assert len(after_stop) > 0.9 * (DURATION_S - STOP_S - MAX_AGE_S) * GYRO_HZ
    assert all(commands[t] == (0.0, 0.0) for t in after_stop)  # zeroed, not held
    live = [t for t in stamps if enc[0] + int(MAX_AGE_S * 1e9) < t <= enc[-1]]
    assert live and all(commands[t] != (0.0, 0.0) for t in live)
    # counted: the last report's stale count is the zeroed commands up to its stamp
    t_diag, values = diagnostics[-1]
    assert t_diag > stale_from
    assert int(values["stale_commands"]) == sum(t <= t_diag for t in zeroed) > 0
    assert int(values["accepted_gyro"]) == sum(t <= t_diag for t in stamps)
    assert int(values["incompatible_qos"]) == 0
