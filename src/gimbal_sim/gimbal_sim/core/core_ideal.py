"""Idealised stages for :func:`.core_loop.run_stages`: what paper 1's analysis runners
(``experiments.bias_ekf``, ``experiments.closed_loop``) put where the graph has a node, to
measure one part of the loop alone (no ROS, no node behind them, no bag: the published
figures come from scenarios' runs). They read the truth, which no deployed node can.

* :func:`truth_stabilizer_stage`: the gimbal held from the *true* attitude and rates
  (:class:`TruthStabilizer`), so that an estimator run open loop is the only thing measured
  (``experiments.bias_ekf``);
* :func:`ideal_sensor_stage`: the gimbal gyro, encoders and INS rates read from the truth,
  the gyro optionally through a :class:`..sensors.GyroModel` (``experiments.closed_loop``);
* :func:`command_delay_stage`: the command applied a number of steps late.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Callable

import numpy as np

from gimbal_kinematics.maths.rotations import quat_to_dcm, rotation_vector_from_dcm
from gimbal_kinematics.maths.sighting_chain import task_to_joint_rates

from .core_stages import Bus
from ..world.sensor_suite import EncoderSample, GimbalGyroSample, InsSample
from ..world.sensors import GyroModel
from ..world.vehicle import VehicleTruth


class TruthStabilizer:
    """Idealised LOS hold from truth: inertial-rate command ω_cmd = −k C_mn ε (ε the n-frame
    rotation from the held attitude) mapped to joint rates (``task_to_joint_rates``), then a
    PI on the joint-rate error: τ = k_d e + k_i ∫e. Optional elevation scan (sinusoid)."""

    def __init__(self, dt: float, k_los: float = 2.0, k_d: float = 1.0, k_i: float = 10.0,
                 scan_amplitude_deg: float = 0.0, scan_period_s: float = 40.0) -> None:
        self.dt, self.k_los, self.k_d, self.k_i = dt, k_los, k_d, k_i
        self.scan_rate = math.radians(scan_amplitude_deg) * 2.0 * math.pi / scan_period_s
        self.scan_w = 2.0 * math.pi / scan_period_s
        self._target: np.ndarray | None = None
        self._integ = [0.0, 0.0]

    def command(self, truth: VehicleTruth) -> tuple[float, float]:
        C = quat_to_dcm(truth.quat_nm)
        if self._target is None:
            self._target = C
        else:
            # The held attitude turns about m-y for the elevation scan.
            wy = self.scan_rate * math.cos(self.scan_w * truth.t) * self.dt
            c, s = math.cos(wy), math.sin(wy)
            self._target = self._target @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        eps = rotation_vector_from_dcm(C @ self._target.T)
        w_cmd = -self.k_los * (C.T @ eps)
        psi_t, psi_m, theta_m = truth.joint_position
        qd = task_to_joint_rates(float(w_cmd[1]), float(w_cmd[2]), np.asarray(truth.omega_ib_b), psi_t,
                                 truth.joint_velocity[0], psi_m, theta_m)
        e = (qd[0] - truth.joint_velocity[1], qd[1] - truth.joint_velocity[2])
        self._integ = [self._integ[0] + e[0] * self.dt, self._integ[1] + e[1] * self.dt]
        return (self.k_d * e[0] + self.k_i * self._integ[0], self.k_d * e[1] + self.k_i * self._integ[1])


def truth_stabilizer_stage(stabilizer: TruthStabilizer) -> Callable[[Bus], None]:
    """The step's command from ``stabilizer`` on the step's truth (in place of a controller)."""

    def stage(bus: Bus) -> None:
        bus.command = stabilizer.command(bus.truth)
    return stage


def ideal_sensor_stage(gyro: GyroModel | None = None) -> Callable[[Bus], None]:
    """Every sensor every step, from the truth of the step: gimbal gyro (q_m, r_m) the true
    inertial rate of m about its y, z (through ``gyro`` when given, else exact), encoders
    the true joint angles and rates, INS the true Euler angles and body rates."""

    def stage(bus: Bus) -> None:
        tr = bus.truth
        wm = tr.omega_im_m
        if gyro is None:
            q, r, bias = wm[1], wm[2], (0.0, 0.0)
        else:
            q, r = gyro.step_rate((wm[1], wm[2]))
            bias = tuple(gyro.true_bias_values())
        bus.gyro = GimbalGyroSample(tr.t, q, r, bias)
        bus.encoders = EncoderSample(tr.t, tr.joint_names, tr.joint_position, tr.joint_velocity)
        bus.ins = InsSample(tr.t, tr.euler, tr.omega_ib_b, (0.0, 0.0, 0.0))
        bus.ins_euler = tr.euler
    return stage


def command_delay_stage(samples: int, command_size: int = 2) -> Callable[[Bus], None]:
    """The step's command replaced by the one of ``samples`` steps before (zero before the
    first); no command this step counts as the held zero command."""
    zero = (0.0,) * command_size
    queue: deque = deque([zero] * samples)

    def stage(bus: Bus) -> None:
        queue.append(bus.command if bus.command is not None else zero)
        bus.command = queue.popleft()
    return stage
