"""A bag's recorded sensor topics fed into the gyro-bias EKF core, as the ``gyro_bias_ekf``
node feeds them and through the engine's own step of that node (one stamp's samples in the
node's order, :func:`gimbal_estimators.gyro_bias_ekf_stamp.feed_stamp`, which the engine's
``gyro_bias_ekf`` stage calls): what ``gimbal-report --report consistency`` judges, what
``gimbal-bench`` times as the replay limit and what ``tools.replay_speed`` checks the node against.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Iterator

from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput, feed_stamp
from gimbal_kinematics.maths.rotations import euler321_from_quat
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.timing.sync import RateSync

from .reader import read_messages

#: The recorded topics the EKF reads.
EKF_INPUTS = ("/gimbal/imu", "/gimbal/joint_states", "/ins/imu")


#: The node's order within a stamp: encoders and INS before the gyro.
_EKF_RANK = {"/gimbal/joint_states": 0, "/ins/imu": 1, "/gimbal/imu": 2}


def ekf_outputs(messages: list, ekf: EkfInput, t0_ns: int | None = None) -> Iterator[tuple[int, Any]]:
    """Feed recorded sensor messages (``RawMessage``s of :data:`EKF_INPUTS`, sorted here by
    log time, the node's order within a stamp) into ``ekf`` as the ``gyro_bias_ekf`` node
    does, one stamp at a time through the engine's step
    (:func:`gimbal_estimators.gyro_bias_ekf_stamp.feed_stamp`); yield ``(stamp [ns], output)``
    for every :class:`EkfOutput` the core produces.

    Times go to the core as seconds from ``t0_ns`` (default: the first stamp, as the node
    does in free timing; the lockstep node uses 0), so an epoch start near 1.8e9 s keeps
    nanosecond resolution.
    """
    messages = sorted(messages, key=lambda msg: (msg.log_time_ns, _EKF_RANK[msg.topic]))
    outputs: list = []
    for stamp_ns, group in _stamps(messages):
        t0_ns = stamp_ns if t0_ns is None else t0_ns
        feed_stamp(ekf, (stamp_ns - t0_ns) * 1e-9, group.get("/gimbal/joint_states"), group.get("/ins/imu"),
                   group.get("/gimbal/imu"), outputs.append)
        for out in outputs:
            yield t0_ns + int(round(out.t * 1e9)), out
        outputs.clear()


def _stamps(messages: list) -> Iterator[tuple[int, dict[str, tuple]]]:
    """The sorted messages decoded, as runs of consecutive messages of one header stamp in
    the node's order (a message out of that order, or of another stamp, starts the next run):
    ``(stamp [ns], {topic: the core's arguments})``, so that the core gets every message in
    the bag's order at its own stamp."""
    group: dict[str, tuple] = {}
    stamp = rank = None
    for msg in messages:
        if msg.topic == "/gimbal/joint_states":
            d = m.joint_state_from_cdr(msg.data)
            args: tuple = (d.position, d.velocity)
        else:
            d = m.imu_from_cdr(msg.data)
            args = ((d.angular_velocity[1], d.angular_velocity[2]) if msg.topic == "/gimbal/imu"
                    else (euler321_from_quat(d.orientation), d.angular_velocity))
        r = _EKF_RANK[msg.topic]
        if group and (d.stamp_ns != stamp or r <= rank):
            yield stamp, group
            group = {}
        group[msg.topic], stamp, rank = args, d.stamp_ns, r
    if group:
        yield stamp, group


def replay_bag(bag: Path, values: dict[str, Any]) -> tuple[float, float, float, int] | None:
    """Replay a bag's sensor topics into the EKF core (built from the ``gyro_bias_ekf``
    node's parameter ``values``) as fast as it goes: (simulated s, wall s and CPU s spent
    decoding and filtering, updates), or None when the bag lacks a topic."""
    messages, _ = read_messages(bag, set(EKF_INPUTS))
    if {msg.topic for msg in messages} != set(EKF_INPUTS):
        return None
    ekf = EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values(values)), RateSync)
    t0, c0 = time.perf_counter(), time.process_time()
    updates = sum(1 for _ in ekf_outputs(messages, ekf, t0_ns=0))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return (max(x.log_time_ns for x in messages) - min(x.log_time_ns for x in messages)) * 1e-9, wall, cpu, updates
