"""Gimbal geometry of the paper 3 platform plant: its joint angles and its motor torques.

The plant (:mod:`.platform_loops`, stepped by ``VehicleCore``) integrates the stable element
``s`` as three loops about the element's *own* axes relative to the level frame n,
``C_sn = rot1(q) rot2(p) rot3(a)``, plus the outer-roll loop r. The real gimbal set of paper 3
(:mod:`gimbal_kinematics.four_gimbal`) is a chain base → outer roll → pitch → inner roll →
azimuth, ``C_sb = rot3(θ_a) rot1(θ_q) rot2(θ_p) rot1(θ_r)``, whose inner-roll and pitch
motors sit on axes that do not turn with the azimuth. This module maps between the two:

* :func:`gimbal_angles`: the gimbal (joint) angles that realise the plant's attitude on the
  base, ``C_sb = C_sn C_nb``, with the simulated outer-roll angle θ_r. This is what the
  resolvers read (before quantisation, which is the sensor's business).
* :func:`loop_voltages`: the plant-loop voltages equivalent to the four gimbal motor
  voltages. Each motor's torque (k_t/R_a)·V acts about its gimbal axis; resolved on the
  stable element's axes, ``τ_s = τ_a e3 + C_sq (τ_q e1 + τ_p C_qp e2)`` with
  ``C_sq = rot3(θ_a)`` and ``C_qp e2 = (0, cos θ_q, −sin θ_q)``, and turned back into the
  voltages of the loops about s-z, s-x and s-y. The outer-roll voltage drives the outer-roll
  loop directly; that loop does not move the stable element in this plant.

Both are exact for the attitude; the loops' back-EMF and friction still act on the loop rates
(the motors' own rates differ from them by the θ_a resolution, which matters only for the
≈ 1 % back-EMF damping).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from gimbal_kinematics.four_gimbal import gimbal_angles_from_dcm
from gimbal_kinematics.rotations import rot1, rot2, rot3


def gimbal_angles(loop_angles: Sequence[float], C_nb: np.ndarray) -> tuple[float, float, float, float]:
    """Gimbal angles (θ_a, θ_q, θ_p, θ_r) [rad] of the plant state on its base.

    ``loop_angles``: the plant's (a, q, p, r) loop angles [rad] (a multi-turn); ``C_nb``
    (3, 3): base to NED. θ_a is returned multi-turn, continuous with the loop azimuth a minus
    the base heading (a resolver-to-digital converter that counts turns), so a platform that
    sweeps 360° reads 0 → 2π rather than wrapping. Raises ``ValueError`` at gimbal lock.
    """
    a, q, p, r = (float(v) for v in loop_angles)
    C_sb = rot1(q) @ rot2(p) @ rot3(a) @ C_nb
    ga, gq, gp, gr = (float(v) for v in gimbal_angles_from_dcm(C_sb, r))
    ref = a - math.atan2(C_nb[1, 0], C_nb[0, 0])  # ≈ θ_a up to small tilt terms
    return ref + math.remainder(ga - ref, math.tau), gq, gp, gr


def loop_voltages(motor_volts: Sequence[float], angles: Sequence[float],
                  torque_per_volt: Sequence[float]) -> tuple[float, float, float, float]:
    """Plant loop voltages (a, q, p, r) [V] for gimbal motor voltages (a, q, p, r) [V].

    ``angles``: gimbal angles (θ_a, θ_q, ...) [rad]; ``torque_per_volt``: k_t/R_a of the
    motors (a, q, p, r) [N·m/V], the same motors drive the loops (module docstring).
    """
    va, vq, vp, vr = motor_volts
    ka, kq, kp, _ = torque_per_volt
    ta, tq, tp = ka * va, kq * vq, kp * vp
    ca, sa = math.cos(angles[0]), math.sin(angles[0])
    cq, sq = math.cos(angles[1]), math.sin(angles[1])
    # in q: τ_q e1 + τ_p (0, cos θq, −sin θq); C_sq = rot3(θa) maps q to s
    x, y, z = tq, tp * cq, -tp * sq
    tx, ty, tz = ca * x + sa * y, -sa * x + ca * y, z + ta
    return tz / ka, tx / kq, ty / kp, float(vr)
