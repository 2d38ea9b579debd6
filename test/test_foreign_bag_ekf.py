"""Acceptance: a bag written by ``rosbags`` (a library we did not write), MCAP and
sqlite3, default volatile QoS in its metadata, stamps shifted to an epoch time near 1.8e9 s,
replays with ``gimbal-bag play --rate 0`` into a fresh ``gyro_bias_ekf`` started alone
from its executable (free timing, its default; only its estimates are offered
transient-local, so the test's reader cannot lose the first ones to discovery). Every INS
sample gets an estimate, and the
estimates equal the EKF core fed directly from the same bag (read by rosbags, not by our
reader or CDR code) to 1e-9 rad/s.

The sensor data come from a short lockstep run (``sim_open_loop``: the land vehicle, its
INS, gimbal gyro and encoders); their messages are decoded by rosbags, re-stamped (header
and log time) at :data:`EPOCH_NS` + sim time and written again by rosbags.
"""
from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN
from foreign_bags import DEFAULT_QOS, EPOCH_NS, TYPESTORE
from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import PARAMS, GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput
from gimbal_kinematics.maths.rotations import euler321_from_quat
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.timing.sync import RateSync
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros
INPUTS = ("/gimbal/imu", "/gimbal/joint_states", "/ins/imu")
#: The node's order within one stamp: encoders and INS before the gyro.
RANK = {"/gimbal/joint_states": 0, "/ins/imu": 1, "/gimbal/imu": 2}
DURATION_S = 4.0


@pytest.fixture(scope="module")
def source_bag(module_ros_domain_env, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("src") / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "sim_open_loop", "--duration", str(DURATION_S),
                             "--out", str(out), "--mode", "container", "--no-progress"], env=module_ros_domain_env,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return out


def _shift(msg, offset_ns: int):
    t = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + offset_ns
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 1_000_000_000)
    return msg


@pytest.fixture(scope="module", params=["mcap", "sqlite3"])
def foreign_bag(request, source_bag, tmp_path_factory) -> Path:
    """The run's EKF inputs, re-stamped at the epoch and written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    path = tmp_path_factory.mktemp("foreign") / f"bag_{request.param}"
    plugin = StoragePlugin.SQLITE3 if request.param == "sqlite3" else StoragePlugin.MCAP
    with AnyReader([source_bag], default_typestore=TYPESTORE) as reader, \
            Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {c.topic: c for c in reader.connections if c.topic in INPUTS}
        out = {t: writer.add_connection(t, c.msgtype, typestore=TYPESTORE, offered_qos_profiles=[DEFAULT_QOS])
               for t, c in conns.items()}
        for conn, t_ns, data in reader.messages(connections=list(conns.values())):
            msg = _shift(TYPESTORE.deserialize_cdr(data, conn.msgtype), EPOCH_NS)
            writer.write(out[conn.topic], t_ns + EPOCH_NS, TYPESTORE.serialize_cdr(msg, conn.msgtype))
    return path


def core_estimates(bag: Path) -> tuple[dict[int, np.ndarray], list[int]]:
    """({stamp [ns]: bias (3,)} of the EKF core fed the bag's messages in the node's order,
    with times relative to the first stamp as the free-timing node keeps them, and the
    INS stamps), all decoded by rosbags."""
    ekf = EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values({p.name: p.default for p in PARAMS})), RateSync)
    with AnyReader([bag], default_typestore=TYPESTORE) as reader:
        items = []
        for conn, _, data in reader.messages(connections=[c for c in reader.connections if c.topic in INPUTS]):
            msg = reader.deserialize(data, conn.msgtype)
            items.append((msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, RANK[conn.topic], msg))
    items.sort(key=lambda x: (x[0], x[1]))
    t0 = items[0][0]
    estimates, ins = {}, []
    for t_ns, rank, msg in items:
        t = (t_ns - t0) * 1e-9
        if rank == 2:
            ekf.on_gyro(t, msg.angular_velocity.y, msg.angular_velocity.z)
        elif rank == 0:
            ekf.on_encoders(t, list(msg.position), list(msg.velocity))
        else:
            ins.append(t_ns)
            q = msg.orientation
            w = msg.angular_velocity
            ekf.on_ins(t, euler321_from_quat((q.x, q.y, q.z, q.w)), (w.x, w.y, w.z))
        for out in ekf.take_outputs():
            estimates[t0 + int(round(out.t * 1e9))] = np.array(out.bias)
    return estimates, ins


def test_foreign_bag_replays_into_a_fresh_ekf_exactly(foreign_bag, ros_domain_env, tmp_path):
    want, ins_stamps = core_estimates(foreign_bag)
    assert len(ins_stamps) >= 0.9 * DURATION_S * 100 and len(want) >= 0.9 * len(ins_stamps)
    info = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(foreign_bag)], capture_output=True, text=True,
                          timeout=60)
    assert info.returncode == 0, info.stderr
    assert all(t in info.stdout for t in INPUTS)
    got: dict[int, np.ndarray] = {}
    # Discovery matches each direction on its own: this reader may see the node's publisher
    # before the node's publisher has matched it, and a volatile writer sends nothing to a
    # reader it has not matched. So the estimates are offered transient-local (a QoS override
    # parameter; the node's computation and its inputs' QoS are its defaults) with room for
    # all of them, and a reader matched late still gets every one.
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
    # Alone, the node takes its inputs best effort (SensorDataQoS), as from a driver; an exact
    # replay needs every sample, whatever the load, so its inputs are made reliable (the same
    # kind of override) and the pacing player waits for the node, never for the network.
    bias_qos = {"qos_overrides./gyro_bias_ekf/bias.publisher.durability": "transient_local",
                "qos_overrides./gyro_bias_ekf/bias.publisher.depth": len(ins_stamps),
                **{f"qos_overrides.{t}.subscription.reliability": "reliable" for t in INPUTS}}
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        sub = node.create_subscription(Vector3Stamped, "/gyro_bias_ekf/bias",
                                 lambda msg: got.__setitem__(m.stamp_ns(msg.header.stamp),
                                                             np.array([msg.vector.x, msg.vector.y, msg.vector.z])),
                                 keep_all)
        with node_processes([("gyro_bias_ekf", bias_qos)], ros_domain_env, tmp_path):
            assert spin_until(executor, lambda: sub.get_publisher_count() >= 1, 120.0)
            play = subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(foreign_bag), "--rate", "0",
                                     "--pace", "/gyro_bias_ekf/progress", "--wait-for-subscribers", "1"],
                                    env=ros_domain_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            try:
                delivered = spin_until(executor, lambda: set(ins_stamps) <= set(got), 180.0)
                if not delivered:
                    play.kill()  # a stalled player would hold communicate() for its whole timeout
                out, err = play.communicate(timeout=60)
            finally:
                if play.poll() is None:
                    play.kill()
                    play.wait()
    # the player's and the node's own words are what tell a stalled handshake from a slow machine
    context = f"gimbal-bag play (exit {play.returncode}) stdout:\n{out}\nstderr:\n{err}\n" \
              f"gyro_bias_ekf log:\n{(tmp_path / 'gyro_bias_ekf.log').read_text()[-4000:]}"
    assert delivered, f"{len(set(ins_stamps) - set(got))} INS samples without an estimate\n{context}"
    assert play.returncode == 0, context
    assert set(got) == set(ins_stamps)      # one estimate per INS sample, stamped like it
    for t_ns, bias in want.items():
        assert np.max(np.abs(got[t_ns] - bias)) <= 1e-9, t_ns


def test_consistency_report_on_a_bag_without_truth(foreign_bag, tmp_path):
    """gimbal-report --report consistency on the foreign bag (no truth topics): its figures
    against the core fed by rosbags' reading, and the NIS bounds against scipy's chi-square."""
    import json
    import shutil

    from scipy.stats import chi2

    bag = tmp_path / "bag"
    shutil.copytree(foreign_bag, bag)
    result = subprocess.run([str(VENV_BIN / "gimbal-report"), str(bag), "--report", "consistency"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    metrics = json.loads((bag / "report" / "metrics.json").read_text())
    want, _ = core_estimates(foreign_bag)
    last = want[max(want)]
    assert np.allclose(np.radians(np.array(metrics["bias_final_deg_h"]) / 3600.0), last, rtol=0, atol=1e-12)
    assert metrics["outputs"] == len(want)
    nis = metrics["nis"]
    n = nis["samples"]
    assert n == metrics["updates"] - 1      # every update after the initial alignment
    assert nis["lower_95"] == pytest.approx(chi2.ppf(0.025, 3 * n) / n, rel=1e-9)
    assert nis["upper_95"] == pytest.approx(chi2.ppf(0.975, 3 * n) / n, rel=1e-9)
    assert nis["windows"] == n // 100 and sum(nis["windows_by_verdict"].values()) == n // 100
    assert {"bias_3sigma.png", "innovations.png", "nis.png"} <= set(metrics["plots"])
    assert all((bag / "report" / p).is_file() for p in metrics["plots"])
