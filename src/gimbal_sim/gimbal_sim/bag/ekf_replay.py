"""A bag's recorded sensor topics fed into the gyro-bias EKF core, as the ``gyro_bias_ekf``
node feeds them: what ``gimbal-report --report consistency`` judges and what ``gimbal-bench``
times as the replay limit.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Iterator

from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_kinematics.rotations import euler321_from_quat
from gimbal_kinematics.ros import messages as m

from .reader import read_messages

#: The recorded topics the EKF reads.
EKF_INPUTS = ("/gimbal/imu", "/gimbal/joint_states", "/ins/imu")


#: The node's order within a stamp: encoders and INS before the gyro.
_EKF_RANK = {"/gimbal/joint_states": 0, "/ins/imu": 1, "/gimbal/imu": 2}


def ekf_outputs(messages: list, ekf: GyroBiasEkf, t0_ns: int | None = None) -> Iterator[tuple[int, Any]]:
    """Feed recorded sensor messages (``RawMessage``s of :data:`EKF_INPUTS`, sorted here by
    log time, the node's order within a stamp) into ``ekf`` as the ``gyro_bias_ekf`` node
    does; yield ``(stamp [ns], output)`` for every :class:`EkfOutput` the core produces.

    Times go to the core as seconds from ``t0_ns`` (default: the first stamp, as the node
    does in free timing; the lockstep node uses 0), so an epoch start near 1.8e9 s keeps
    nanosecond resolution.
    """
    messages = sorted(messages, key=lambda msg: (msg.log_time_ns, _EKF_RANK[msg.topic]))
    for msg in messages:
        if msg.topic == "/gimbal/imu":
            d = m.imu_from_cdr(msg.data)
            t0_ns = d.stamp_ns if t0_ns is None else t0_ns
            ekf.on_gyro((d.stamp_ns - t0_ns) * 1e-9, d.angular_velocity[1], d.angular_velocity[2])
        elif msg.topic == "/gimbal/joint_states":
            d = m.joint_state_from_cdr(msg.data)
            t0_ns = d.stamp_ns if t0_ns is None else t0_ns
            ekf.on_encoders((d.stamp_ns - t0_ns) * 1e-9, d.position, d.velocity)
        else:
            d = m.imu_from_cdr(msg.data)
            t0_ns = d.stamp_ns if t0_ns is None else t0_ns
            ekf.on_ins((d.stamp_ns - t0_ns) * 1e-9, euler321_from_quat(d.orientation), d.angular_velocity)
        for out in ekf.take_outputs():
            yield t0_ns + int(round(out.t * 1e9)), out


def replay_bag(bag: Path, values: dict[str, Any]) -> tuple[float, float, float, int] | None:
    """Replay a bag's sensor topics into the EKF core (built from the ``gyro_bias_ekf``
    node's parameter ``values``) as fast as it goes: (simulated s, wall s and CPU s spent
    decoding and filtering, updates), or None when the bag lacks a topic."""
    messages, _ = read_messages(bag, set(EKF_INPUTS))
    if {msg.topic for msg in messages} != set(EKF_INPUTS):
        return None
    ekf = GyroBiasEkf(GyroBiasEkfParams.from_values(values))
    t0, c0 = time.perf_counter(), time.process_time()
    updates = sum(1 for _ in ekf_outputs(messages, ekf, t0_ns=0))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return (max(x.log_time_ns for x in messages) - min(x.log_time_ns for x in messages)) * 1e-9, wall, cpu, updates
