"""The gyro-bias EKF's measurement and error-model helpers (:mod:`.gyro_bias_ekf` explains
the model): the measured attitude C(n,m) from the INS Euler angles and the encoders, its
error Jacobians, the roll-rate error matrix M and the discretised error model (F, Q)."""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from gimbal_kinematics.rotations import dcm_from_rotation_vector, quat_from_euler321, quat_mul


def quat_nb_from_euler(euler: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of C_nb = ``sighting_chain.dcm_nb(φ, θ, ψ)`` (3-2-1 Euler angles [rad])."""
    return quat_from_euler321(euler[0], euler[1], euler[2])


def measured_quat_nm(q_nb: Sequence[float], angles: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of C_nm = C_nb ``sighting_chain.dcm_bm(ψt, ψm, θm)``; C_bm is a turn of
    ψt + ψm about z followed by θm about y, so q_bm = q_z(ψt + ψm) ⊗ q_y(θm)."""
    ha, he = 0.5 * (angles[0] + angles[1]), 0.5 * angles[2]
    ca, sa, ce, se = math.cos(ha), math.sin(ha), math.cos(he), math.sin(he)
    return quat_mul(q_nb, (-sa * se, ca * se, sa * ce, ca * ce))


def ins_error_jacobian(euler: Sequence[float]) -> np.ndarray:
    """J_e (3, 3): n-frame rotation δα of C_nb per Euler-angle error (δφ, δθ, δψ) [rad/rad],
    i.e. C_nb(euler + δ) ≈ (I + [J_e δ ×]) C_nb(euler)."""
    roll, pitch, yaw = euler
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cp * cy, -sy, 0.0], [cp * sy, cy, 0.0], [-sp, 0.0, 1.0]])


def encoder_error_jacobian(q_nb: Sequence[float], q_nm: Sequence[float]) -> np.ndarray:
    """(3, 3): n-frame rotation of C_nm per encoder error (ε_t, ε_m, ε_θ) [rad/rad], from the
    (x, y, z, w) quaternions of C_nb and C_nm: turret and gimbal azimuth turn about
    u = C_nb e3, the elevation about v = C_nm e2."""
    bx, by, bz, bw = q_nb
    mx, my, mz, mw = q_nm
    u0, u1, u2 = 2.0 * (bx * bz + by * bw), 2.0 * (by * bz - bx * bw), 1.0 - 2.0 * (bx * bx + by * by)
    v0, v1, v2 = 2.0 * (mx * my - mz * mw), 1.0 - 2.0 * (mx * mx + mz * mz), 2.0 * (my * mz + mx * mw)
    return np.array([[u0, u0, v0], [u1, u1, v1], [u2, u2, v2]])


def roll_rate_matrix(theta_m: float) -> np.ndarray:
    """M (3, 3): gyro-frame rate error per (δb_x, δb_q, δb_r) — see the module docstring."""
    c, s = math.cos(theta_m), math.sin(theta_m)
    return np.array([[1.0 / c, 0.0, -s / c], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def discretize_error_model(
    A: np.ndarray, T: float, omega_in_n: np.ndarray, n_psd: np.ndarray, qb_psd: np.ndarray,
    pe_var: np.ndarray | None = None, tau_e: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """(F, Q) of the error model over a step ``T`` [s] (module docstring), A = C_nm M held.

    ``A`` (3, 3); ``omega_in_n`` (3,) [rad/s]; ``n_psd`` (3,) white rate-noise PSDs of
    (x, q, r) [rad²/s]; ``qb_psd`` (3,) bias random-walk PSDs [rad²/s³]; ``pe_var`` (3,)
    stationary variances of the INS-error states [rad²] with correlation time ``tau_e``
    [s], or None for the 6-state filter. Shapes (n, n), n = 6 or 9. Terms of relative size
    (|ω_in| T)² and Q's ω_in coupling (|ω_in| T ~ 1e-6 at 100 Hz) are dropped.
    """
    n = 6 if pe_var is None else 9
    F = np.eye(n)
    w = np.asarray(omega_in_n, dtype=float)
    F[:3, :3] = dcm_from_rotation_vector(-T * w)
    # −∫ exp(−[ω_in×](T−s)) A ds, to second order in |ω_in| T (~1e-6).
    wx, wy, wz = w
    Wx = np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
    F[:3, 3:6] = (0.5 * T * T) * (Wx @ A) - T * A
    Q = np.zeros((n, n))
    AQb = A * qb_psd  # A diag(q): the densities are diagonal
    Q[:3, :3] = (A * (np.asarray(n_psd) * T) + AQb * (T**3 / 3.0)) @ A.T
    Q[:3, 3:6] = AQb * (-0.5 * T * T)
    Q[3:6, :3] = Q[:3, 3:6].T
    Q[3:6, 3:6] = np.diag(np.asarray(qb_psd) * T)
    if pe_var is not None:
        decaying = not math.isinf(tau_e)
        F[6:, 6:] *= math.exp(-T / tau_e) if decaying else 1.0
        Q[6:, 6:] = np.diag(np.asarray(pe_var) * (-math.expm1(-2.0 * T / tau_e) if decaying else 0.0))
    return F, Q
