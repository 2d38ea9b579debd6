"""How fast a recorded bag replays into the ``gyro_bias_ekf`` node, and whether exactly.

What a user does with their own recording: start ``gyro_bias_ekf`` alone (free timing, its
default: SensorDataQoS inputs, steps on the message stamps) and ``gimbal-bag play BAG
--rate 0 --pace /gyro_bias_ekf/progress``. :func:`measure` does the same from one process
(the player in-process, the node as its own executable with the run's EKF parameters and
``timing: free``), times the replay from the first published message until the node has
published an estimate for every INS sample, and compares every estimate with the EKF core
fed the same bag directly through the engine's step of that node (:func:`..bag.ekf_replay.ekf_outputs`): the figure counts only if the
two agree to 1e-9 rad/s. ``python -m gimbal_sim.tools.replay_speed BAG`` prints it for a bag.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams, PARAMS
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.timing.sync import RateSync

from ..bag.ekf_replay import EKF_INPUTS, ekf_outputs
from ..graph.orchestrator import _ros_env, stop_processes

EKF = "gyro_bias_ekf"
#: Largest difference [rad/s] between node and core estimates that still counts as exact.
EXACT_RAD_S = 1e-9


@dataclass
class ReplaySpeed:
    sim_s: float              # bag time of the sensor topics [s]
    wall_s: float             # first message published -> last INS sample's estimate received [s]
    messages: int             # sensor messages played
    estimates: int            # estimates received
    ins_samples: int          # INS samples in the bag
    max_diff_rad_s: float     # largest |node - core| bias difference over the shared stamps
    missing: int              # INS samples without an estimate
    node_cpu_s: float         # CPU time of the node process over the replay [s]
    player_cpu_s: float       # CPU time of the player (this process) over the replay [s]

    @property
    def speed_x(self) -> float:
        return self.sim_s / self.wall_s

    @property
    def exact(self) -> bool:
        return self.missing == 0 and self.max_diff_rad_s <= EXACT_RAD_S

    def summary(self) -> str:
        verdict = (f"exact: every INS sample's estimate equals the core's (max |diff| {self.max_diff_rad_s:.1e} "
                   f"rad/s)" if self.exact else
                   f"NOT exact: {self.missing} INS samples without an estimate, max |diff| "
                   f"{self.max_diff_rad_s:.1e} rad/s")
        return (f"{self.speed_x:,.1f}x real time ({self.sim_s:g} s of sensor data, {self.messages} messages, "
                f"in {self.wall_s:.2f} s; node process, free timing, gimbal-bag play --rate 0 --pace; CPU: node "
                f"{self.node_cpu_s:.2f} s = {self.sim_s / self.node_cpu_s:,.1f}x, player {self.player_cpu_s:.2f} s = "
                f"{self.sim_s / self.player_cpu_s:,.1f}x); {verdict}")


def _cpu_s(pid: int) -> float:
    """User + system CPU time [s] of process ``pid`` so far (Linux /proc)."""
    import os

    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def ekf_values(bag: Path, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """The node's parameter values: its defaults, the run's ``params/gyro_bias_ekf.yaml``
    when the bag is one of our runs, then ``overrides``."""
    values = {p.name: p.default for p in PARAMS}
    run_params = Path(bag) / "params" / f"{EKF}.yaml"
    if run_params.is_file():
        for node in (yaml.safe_load(run_params.read_text()) or {}).values():
            values.update((node or {}).get("ros__parameters", {}))
    values.update(overrides or {})
    return values


def measure(bag: Path, timeout_s: float = 600.0) -> ReplaySpeed:
    """Replay ``bag``'s sensor topics into a free-timing ``gyro_bias_ekf`` (module docstring)."""
    import rclpy
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.context import Context
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from gimbal_kinematics.ros.node_main import make_executor
    from ..bag.player import BagPlayer, PlayOptions

    values = ekf_values(bag, {"timing": "free"})
    env, claim = _ros_env()
    got: dict[int, tuple[float, float, float]] = {}
    with tempfile.TemporaryDirectory(prefix="gimbal-replay-speed-") as tmp:
        params = Path(tmp) / "params.yaml"
        params.write_text(yaml.safe_dump({EKF: {"ros__parameters": values}}))
        log = open(Path(tmp) / "node.log", "w")
        proc = subprocess.Popen([str(Path(sys.executable).parent / EKF), "--ros-args", "--params-file", str(params)],
                                env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        context = Context()
        rclpy.init(context=context, domain_id=int(env["ROS_DOMAIN_ID"]))
        try:
            player = BagPlayer(Path(bag), PlayOptions(rate=0.0, topics=list(EKF_INPUTS), wait_for_subscribers=1,
                                                      pace_topics=[f"/{EKF}/progress"], wait_timeout_s=120.0),
                               context=context)
            ins = {x.log_time_ns for x in player.messages if x.topic == "/ins/imu"}
            ins_stamps = {m.imu_from_cdr(x.data).stamp_ns for x in player.messages if x.topic == "/ins/imu"}
            sub = player.create_subscription(
                Vector3Stamped, f"/{EKF}/bias",
                lambda msg: got.__setitem__(m.stamp_ns(msg.header.stamp), (msg.vector.x, msg.vector.y, msg.vector.z)),
                QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE))
            executor = make_executor(context)
            executor.add_node(player)
            deadline = time.monotonic() + 120.0
            while sub.get_publisher_count() < 1 and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            player.wait_for_readers(executor)
            t0, cpu0, node_cpu0 = time.monotonic(), time.process_time(), _cpu_s(proc.pid)
            player.play(executor)
            deadline = time.monotonic() + timeout_s
            while not ins_stamps <= set(got) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            wall, cpu, node_cpu = time.monotonic() - t0, time.process_time() - cpu0, _cpu_s(proc.pid) - node_cpu0
            sim = (max(x.log_time_ns for x in player.messages) - min(x.log_time_ns for x in player.messages)) * 1e-9
            messages = list(player.messages)
            executor.shutdown()
            player.destroy_node()
        finally:
            rclpy.shutdown(context=context)
            stop_processes([proc])
            log.close()
            if claim is not None:
                claim.release()
    core = EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values(values)), RateSync)
    want = {t: out.bias for t, out in ekf_outputs(messages, core)}
    shared = [t for t in want if t in got]
    diff = max((float(np.max(np.abs(np.array(got[t]) - want[t]))) for t in shared), default=float("inf"))
    return ReplaySpeed(sim, wall, len(messages), len(got), len(ins), diff, len(ins_stamps - set(got)), node_cpu, cpu)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m gimbal_sim.tools.replay_speed BAG", file=sys.stderr)
        return 2
    print(measure(Path(args[0])).summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
