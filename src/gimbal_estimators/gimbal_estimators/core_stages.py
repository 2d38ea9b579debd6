"""Pure-core stages of gimbal_estimators' nodes for :mod:`gimbal_sim.core_loop` and
``gimbal-bench`` (no ROS): the gyro-bias EKF fed what its subscriptions carry.
The core is built from the node's parameter values by the node's own
:func:`.gyro_bias_ekf_node.params_from_values`, and fed in the node's order: encoders and
INS before the gyro sample of the same stamp (:class:`.stamp_order.StampOrder`).
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

from gimbal_kinematics.rotations import euler321_from_quat
from gimbal_sim import messages as m
from gimbal_sim.bag.reader import read_messages

from .gyro_bias_ekf import GyroBiasEkf

#: The recorded topics the EKF reads.
EKF_INPUTS = ("/gimbal/imu", "/gimbal/joint_states", "/ins/imu")


def ekf_from_values(values: dict[str, Any]) -> GyroBiasEkf:
    from .gyro_bias_ekf_node import params_from_values  # the node's mapping, one copy

    return GyroBiasEkf(params_from_values(values))


def gyro_bias_ekf_stage(values: dict[str, Any]) -> Callable[[Any], None]:
    """``gyro_bias_ekf``: INS (Euler angles from its quaternion), gyro and encoders of step k;
    leaves the bias estimate on the bus when an update completed (and the whole output,
    with its sigma, in ``bus.ekf``)."""
    ekf = ekf_from_values(values)

    def stage(bus) -> None:
        t = bus.t
        out = None
        if bus.encoders is not None:
            out = ekf.on_encoders(t, bus.encoders.angles, bus.encoders.rates) or out
        if bus.ins is not None:
            out = ekf.on_ins(t, bus.ins_euler, bus.ins.omega_b) or out
        if bus.gyro is not None:
            out = ekf.on_gyro(t, bus.gyro.q_m, bus.gyro.r_m) or out
        bus.bias = None if out is None else tuple(out.bias.tolist())
        bus.ekf = out
    return stage


def replay_bag(bag: Path, values: dict[str, Any]) -> tuple[float, float, float, int] | None:
    """Replay a bag's sensor topics into the EKF core as fast as it goes: (simulated s, wall
    s and CPU s spent decoding and filtering, updates), or None when the bag lacks a topic."""
    messages, _ = read_messages(bag, set(EKF_INPUTS))
    if {msg.topic for msg in messages} != set(EKF_INPUTS):
        return None
    # the node's order within a stamp: encoders and INS before the gyro
    rank = {"/gimbal/joint_states": 0, "/ins/imu": 1, "/gimbal/imu": 2}
    messages.sort(key=lambda msg: (msg.log_time_ns, rank[msg.topic]))
    ekf = ekf_from_values(values)
    updates = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for msg in messages:
        if msg.topic == "/gimbal/imu":
            d = m.imu_from_cdr(msg.data)
            out = ekf.on_gyro(d.stamp_ns * 1e-9, d.angular_velocity[1], d.angular_velocity[2])
        elif msg.topic == "/gimbal/joint_states":
            d = m.joint_state_from_cdr(msg.data)
            out = ekf.on_encoders(d.stamp_ns * 1e-9, d.position, d.velocity)
        else:
            d = m.imu_from_cdr(msg.data)
            out = ekf.on_ins(d.stamp_ns * 1e-9, euler321_from_quat(d.orientation), d.angular_velocity)
        updates += out is not None
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return (messages[-1].log_time_ns - messages[0].log_time_ns) * 1e-9, wall, cpu, updates
