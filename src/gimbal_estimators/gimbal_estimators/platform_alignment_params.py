"""The ``platform_alignment`` node's parameters and --help text, declared once in
:class:`PlatformAlignmentNodeParams`. The mapping to the core's parameters is
:meth:`.rotation_alignment.RotationAlignmentParams.from_values`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, SHARED, TimedParams, declaration, param, same_as

INF = math.inf


@dataclass(frozen=True)
class PlatformAlignmentNodeParams(TimedParams):
    """Paper 3 rotation-modulated fine alignment: 8-state recursive least squares on the platform's level
    accelerometers and azimuth joint angle, estimating the initial misalignment, the north gyro drift and the
    level gyro drifts and accelerometer biases. Publishes the estimates with their sigma once per block.
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate, to turn stamps into steps", 1.0, 100000.0, unit="Hz")
    imu_rate_hz: float = param(1000.0, "platform IMU rate; divides sim_rate_hz", 1e-3, 100000.0, unit="Hz")
    joint_rate_hz: float = param(1000.0, "rate of the azimuth joint topic; divides sim_rate_hz",
        1e-3, 100000.0, unit="Hz")
    joint_topic: str = param("/platform/resolvers", "sensor_msgs/JointState topic carrying the azimuth joint")
    azimuth_joint: str = param("platform_azimuth", "name of the azimuth gimbal joint in joint_topic")
    base_heading_deg: float = param(0.0, "heading the base is taken to have (added to the azimuth joint)",
        -360.0, 360.0, unit="deg")
    lat_deg: float = param(40.0, "latitude of the static base (azimuth is unobservable at the poles)",
        -89.999, 89.999, unit="deg")
    gravity_m_s2: float = param(0.0, "local gravity (0: WGS-84 normal gravity at lat_deg)", 0.0, 100.0, unit="m/s^2")
    accel_noise_ug_rt_hz: float = param(50.0, "accelerometer white-noise density, sets R",
        1e-6, INF, unit="micro-g/sqrt(Hz)")
    block_s: float = param(1.0, "accelerometer averaging block per RLS update", 1e-6, 1e6, unit="s")
    tilt_scale_arcsec: float = param(600.0, "a-priori size of the initial tilts (P0 = I in these units)",
        1e-6, INF, unit="arcsec")
    azimuth_scale_deg: float = param(2.0, "a-priori size of the initial azimuth error", 1e-9, INF, unit="deg")
    north_drift_scale_deg_h: float = param(0.1, "a-priori size of the north drift", 1e-9, INF, unit="deg/h")
    accel_bias_scale_ug: float = param(1000.0, "a-priori size of the level accelerometer biases",
        1e-9, INF, unit="micro-g")
    gyro_drift_scale_deg_h: float = param(0.1, "a-priori size of the level gyro drifts", 1e-9, INF, unit="deg/h")
    sensor_error_states: bool = param(True, "estimate the level accelerometer biases and gyro drifts (false: the "
        "classical static gyrocompass, which takes them as zero: the east drift goes into the azimuth)")
    max_joint_age_s: float = param(0.1, "largest gap between an accelerometer sample and the joint sample "
        "extrapolated to it", 1e-9, INF, unit="s")
    converged_tilt_arcsec: float = param(5.0, "tilt sigma below which the estimate counts as converged",
        1e-9, INF, unit="arcsec")
    converged_azimuth_arcmin: float = param(2.0, "azimuth sigma below which it counts as converged",
        1e-9, INF, unit="arcmin")
    clock_jump_s: float = param(1.0, "a stamp this far before the last one restarts the alignment",
        1e-9, INF, unit="s", aliases=CLOCK_JUMP_ALIASES)
    max_sync_wait_s: float = param(0.05, "free timing: longest a sample waits for the other stream's stamp to pass "
        "it (stamp order)", 0.0, 10.0, unit="s")
    diagnostics_period_s: float = param(1.0, "free timing: counters and NIS on /diagnostics every this much stamp "
        "time", 1e-3, 1e6, unit="s")
    nis_window: int = param(50, "free timing: block updates in the NIS window on /diagnostics", 1, 10**6)
    progress_every_steps: int = same_as(SHARED["progress_every_steps"])
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])


PARAMS, DESCRIPTION = declaration(PlatformAlignmentNodeParams)
