"""The names a node gives its input streams: the key its timing policy groups a topic's
samples by into steps (``LockstepControl``, ``FreeControl``), and the word its warnings use.

A :class:`~enum.StrEnum`: each member is its short string, so the policies' keys, the
warnings and the diagnostics read exactly as the strings did.
"""
from __future__ import annotations

from enum import StrEnum


class InputKind(StrEnum):
    GYRO = "gyro"          # the gimbal's rate gyro, /gimbal/imu
    ENCODERS = "enc"       # the gimbal's joint encoders, /gimbal/joint_states
    INS = "ins"            # the host's INS, /ins/imu
    ATTITUDE = "att"       # an estimate of the sight's attitude (the EKF's), a node's attitude_topic
    BIAS = "bias"          # the gyro-bias estimate, a node's bias_topic
    OPERATOR = "op"        # the operator's rate command, a node's operator_topic
    HOST = "base"          # the host body's rates, /truth/host/imu
    FIX = "fix"            # the vehicle's position fix, a node's vehicle_fix_topic
    VELOCITY = "vel"       # the vehicle's velocity, a node's vehicle_velocity_topic
