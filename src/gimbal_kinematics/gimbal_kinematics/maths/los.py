"""The line of sight seen from inertial space: its direction over a run, pointing error and
drift (paper 1's stabilization figures).

The LOS is the inner-gimbal x axis; ``los_from_quat`` gives it in n from the quaternion of
C(n,m). NED turns with the earth, so a direction fixed in inertial space, seen from NED at
time t, turns by exp(−[ω_in^n ×] t); :func:`inertial_los` undoes that, carrying each LOS to
the inertial frame that coincides with NED at t = 0 (a fixed site: ω_in^n constant).
"""
from __future__ import annotations

import math

import numpy as np


def los_from_quat(quats_nm: np.ndarray) -> np.ndarray:
    """LOS unit vectors (N, 3) in n: first column of C(n,m) from quaternions (N, 4) (x, y, z, w)."""
    q = np.asarray(quats_nm, dtype=float).reshape(-1, 4)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.column_stack((1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)))


def inertial_los(los_n: np.ndarray, t: np.ndarray, omega_in_n: np.ndarray) -> np.ndarray:
    """LOS unit vectors (N, 3) resolved in n(t) → in n(0), the inertial frame [Rodrigues
    with the rotation vector ω_in^n t]; ``t`` (N,) [s] from the start, ω [rad/s] (3,)."""
    w = np.asarray(omega_in_n, dtype=float)
    rate = float(np.linalg.norm(w))
    los_n = np.asarray(los_n, dtype=float)
    if rate == 0.0:
        return los_n.copy()
    k = w / rate
    ang = rate * np.asarray(t, dtype=float)[:, None]
    kxv = np.cross(k, los_n)
    kdv = los_n @ k
    return los_n * np.cos(ang) + kxv * np.sin(ang) + np.outer(kdv, k) * (1.0 - np.cos(ang))


def pointing_error(los_i: np.ndarray) -> np.ndarray:
    """Angle [rad] between each LOS (N, 3) and the first one, (N,)."""
    ref = los_i[0]
    cross = np.linalg.norm(np.cross(los_i, ref), axis=1)
    return np.arctan2(cross, los_i @ ref)


def los_az_el(los_i: np.ndarray) -> np.ndarray:
    """Azimuth and elevation [rad] of unit LOS vectors (N, 3) in a NED-like frame, (N, 2);
    azimuth unwrapped, elevation positive up."""
    az = np.unwrap(np.arctan2(los_i[:, 1], los_i[:, 0]))
    el = np.arctan2(-los_i[:, 2], np.hypot(los_i[:, 0], los_i[:, 1]))
    return np.column_stack((az, el))


def los_drift(los_i: np.ndarray) -> np.ndarray:
    """Drift [rad] of the LOS from its first direction, (N, 2): (Δaz · cos el0, Δel). The
    azimuth part is cross-elevation, the angle swept about the local vertical of the LOS, so
    a gyro bias b about the inner-gimbal z (y) axis sweeps −∫b dt in the first (second)."""
    ae = los_az_el(los_i)
    d = ae - ae[0]
    d[:, 0] *= math.cos(ae[0, 1])
    return d
