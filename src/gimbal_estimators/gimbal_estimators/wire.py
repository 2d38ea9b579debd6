"""The serialisation of gimbal_estimators' nodes: pure functions from a core's output to the
messages' bytes (CDR), rclpy-free, which the node publishes and the no-ROS engine writes into
its bag. Each returns ``[(topic, type name, bytes), ...]`` in the node's publishing order,
the topic as the node declares it (``~/x`` relative to the node's name).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from gimbal_kinematics.maths.frames import BASE_FRAME, GIMBAL_FRAME, LGU1_FRAME, NAV_FRAME, PLATFORM_FRAME
from gimbal_kinematics.ros.wire import (
    IMU, NAVSAT_FIX, NOT_PROVIDED, ODOMETRY, VECTOR3_STAMPED, imu_cdr, navsat_fix_cdr, odometry_cdr, vector3_cdr,
)

from .free_gyro_positioning import navsat_covariance_enu

Messages = list[tuple[str, str, bytes]]


def ekf_messages(t_ns: int, bias: Sequence[float], sigma: Sequence[float], quat_nm: Sequence[float] | None,
                 attitude_cov, corrected_rate: Sequence[float] | None) -> Messages:
    """``gyro_bias_ekf``: one output: the bias estimate and its 1σ [rad/s] (0, q, r), and the
    attitude estimate (x, y, z, w) with its 3×3 covariance [rad²] (not provided before the
    alignment: ``quat_nm`` None) and the bias-corrected inner-gimbal rate [rad/s]."""
    cov = NOT_PROVIDED if attitude_cov is None else tuple(float(v) for row in attitude_cov for v in row)
    return [("~/bias", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, bias)),
            ("~/bias_sigma", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, sigma)),
            ("~/attitude", IMU, imu_cdr(t_ns, NAV_FRAME, orientation=quat_nm, orientation_cov=cov,
                                        angular_velocity=corrected_rate))]


def navigator_messages(t_ns: int, fix=None, command_rate_n: Sequence[float] | None = None,
                       odom: tuple | None = None) -> Messages:
    """``platform_navigator``: with ``fix`` (an output whose fix is due: lat, lon [rad], height
    [m], velocity_n [m/s]) its ``~/fix`` (NavSatFix, covariance unknown), ``~/velocity`` (NED)
    and ``~/odom`` (``odom``: the Odometry's frame, child frame and
    :class:`.navigator_odometry.NavigatorOdometry` values); then, once there is one, the
    command rate ω_c^n [rad/s] on ``~/command_rate``."""
    msgs = []
    if fix is not None:
        msgs += [("~/fix", NAVSAT_FIX, navsat_fix_cdr(t_ns, NAV_FRAME, fix.lat, fix.lon, fix.height)),
                 ("~/velocity", VECTOR3_STAMPED, vector3_cdr(t_ns, NAV_FRAME, fix.velocity_n))]
        if odom is not None:
            msgs.append(("~/odom", ODOMETRY, odometry_cdr(t_ns, *odom)))
    if command_rate_n is not None:
        msgs.append(("~/command_rate", VECTOR3_STAMPED, vector3_cdr(t_ns, NAV_FRAME, command_rate_n)))
    return msgs


#: ``flexure_estimator``'s output stems, each published with a ``_sigma`` companion.
FLEXURE_OUTPUTS = ("flexure", "quasi_static", "dynamic", "bias_diff")


def flexure_messages(t_ns: int, est) -> Messages:
    """``flexure_estimator``: one estimate (:class:`.flexure_kf.FlexureEstimate`), each of
    its four quantities [rad, rad/s] and 1σ on ``~/<stem>`` and ``~/<stem>_sigma``, in LGU1
    axes."""
    return [(f"~/{stem}{suffix}", VECTOR3_STAMPED, vector3_cdr(t_ns, LGU1_FRAME, getattr(est, stem + suffix)))
            for stem in FLEXURE_OUTPUTS for suffix in ("", "_sigma")]


# --- paper 3 rotation-modulated alignment ---------------------------------------------------
#: Standard-deviation component of a vector element the estimator does not estimate
#: (the REP 145 "not provided" marker, used per element).
NOT_ESTIMATED = -1.0


def enu_to_ned(v: Sequence[float]) -> tuple[float, float, float]:
    """Components (E, N, U) → (N, E, D) of the same vector."""
    return float(v[1]), float(v[0]), -float(v[2])


def sigma_enu_to_ned(s: Sequence[float]) -> tuple[float, float, float]:
    """Standard deviations (E, N, U) → (N, E, D)."""
    return float(s[1]), float(s[0]), float(s[2])


def planar(v: Sequence[float], sigma: bool = False) -> tuple[float, float, float]:
    """An (x, y) estimate as a 3-vector: z = 0, or the not-estimated marker for a σ vector."""
    return float(v[0]), float(v[1]), NOT_ESTIMATED if sigma else 0.0


def north_only(value: float, sigma: bool = False) -> tuple[float, float, float]:
    """A north component as an NED vector (east/down 0, or not-estimated for a σ vector)."""
    rest = NOT_ESTIMATED if sigma else 0.0
    return float(value), rest, rest


def alignment_messages(t_ns: int, e) -> Messages:
    """``platform_alignment``: one block's estimate (:class:`.rotation_alignment.AlignmentEstimate`):
    the misalignment now and at the start (NED, frame ``map_ned``), the north drift, the level
    gyro drifts and accelerometer biases (frame ``platform_frd``), each with its σ (an
    element not estimated: :data:`NOT_ESTIMATED`), and the status (age [s], updates,
    converged)."""
    nav, plat = NAV_FRAME, PLATFORM_FRAME
    out = (
        ("misalignment", nav, enu_to_ned(e.misalignment_enu)),
        ("misalignment_sigma", nav, sigma_enu_to_ned(e.misalignment_sigma_enu)),
        ("initial_misalignment", nav, enu_to_ned(e.misalignment0_enu)),
        ("initial_misalignment_sigma", nav, sigma_enu_to_ned(e.misalignment0_sigma_enu)),
        ("north_drift", nav, north_only(e.north_drift)),
        ("north_drift_sigma", nav, north_only(e.north_drift_sigma, sigma=True)),
        ("gyro_drift", plat, planar(e.gyro_drift_xy)),
        ("gyro_drift_sigma", plat, planar(e.gyro_drift_sigma_xy, sigma=True)),
        ("accel_bias", plat, planar(e.accel_bias_xy)),
        ("accel_bias_sigma", plat, planar(e.accel_bias_sigma_xy, sigma=True)),
        ("status", plat, (e.age_s, float(e.n_updates), 1.0 if e.converged else 0.0)),
    )
    return [(f"~/{name}", VECTOR3_STAMPED, vector3_cdr(t_ns, frame, vec)) for name, frame, vec in out]


# --- paper 4 free-gyro positioning -----------------------------------------------------------
#: ``~/geometry``'s z: the fix was solved, or its geometry was degenerate (no fix published)
FREE_GYRO_STATUS_FIX, FREE_GYRO_STATUS_DEGENERATE = 0.0, 1.0


def free_gyro_fix_messages(fix, t_close: float, height_m: float, height_sigma_m: float, prediction=None,
                           earth_rate_window_s: float | None = None) -> Messages:
    """``free_gyro_positioning``: one window's fix (:class:`.free_gyro_positioning.FreeGyroFix`),
    stamped at the window's mean time, closed at ``t_close`` [s]: its geometry (FDOP,
    crossing angle, status) and nadir; when valid, the NavSatFix (``height_m`` as altitude,
    the ENU covariance with ``height_sigma_m``²) and heading (with the window's span), and
    the error model's ``prediction`` (:class:`.free_gyro_error_model.ErrorPrediction`) when
    given; the earth-rate heading (stamped at its own time) when ``earth_rate_window_s``."""
    stamp = int(round(fix.t * 1e9))
    status = FREE_GYRO_STATUS_FIX if fix.valid else FREE_GYRO_STATUS_DEGENERATE
    out = [("~/geometry", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME, (fix.fdop, fix.crossing_angle, status))),
           ("~/nadir", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME, (fix.nadir[0], fix.nadir[1], fix.nadir_sigma)))]
    if fix.valid:
        cov = navsat_covariance_enu(fix.cov_ne_m, height_sigma_m**2)
        span = 2.0 * (t_close - fix.t)  # uniform read-outs: the window is symmetric about its mean time
        out += [("~/fix", NAVSAT_FIX, navsat_fix_cdr(stamp, BASE_FRAME, fix.lat, fix.lon, height_m, cov)),
                ("~/heading", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME, (fix.heading, fix.heading_sigma, span)))]
        if prediction is not None:
            out += _prediction_messages(stamp, prediction)
    if earth_rate_window_s is not None:
        out.append(("~/heading_earth_rate", VECTOR3_STAMPED, vector3_cdr(
            int(round(fix.heading_earth_rate_t * 1e9)), BASE_FRAME,
            (fix.heading_earth_rate, fix.heading_earth_rate_sigma, earth_rate_window_s))))
    return out


def _prediction_messages(stamp: int, pred) -> Messages:
    """The error model's σ of a fix: nadir (σa, σb, their correlation), position (σN, σE
    [m], correlation), heading (σ, σ of the earth-rate heading, the position FDOP [m])."""
    c = pred.cov
    sd = np.sqrt(np.diag(c))
    corr = [float(c[i, i + 1] / (sd[i] * sd[i + 1])) if sd[i] > 0.0 and sd[i + 1] > 0.0 else 0.0 for i in (0, 2)]
    return [("~/predicted_nadir", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME, (sd[0], sd[1], corr[0]))),
            ("~/predicted_position", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME, (sd[2], sd[3], corr[1]))),
            ("~/predicted_heading", VECTOR3_STAMPED, vector3_cdr(stamp, BASE_FRAME,
                                                                 (sd[4], sd[5], pred.position_fdop_m)))]
