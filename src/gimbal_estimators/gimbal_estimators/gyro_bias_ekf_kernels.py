"""Compiled per-sample kernels of the gyro-bias EKF (numba ``njit``): plain functions over
floats and float64 arrays. :class:`.gyro_bias_ekf.GyroBiasEkf` holds the state (the
quaternion Ĉ(n,m), the biases, the covariance P (n, n), n = 6 or 9, in the index order of
:mod:`.gyro_bias_ekf_model`) and calls them; the engine's compiled sighting loop calls the
same ones, so both compute the same bits. The matrix products are written as loops (no
BLAS, whose summation order depends on the CPU).

Mechanization (:func:`mechanize`), with the rotation vector of the step
φ = ½(ω₀ + ω₁)Δt + (Δt²/12) ω₀ × ω₁::

    Ĉ ← exp(−[ω_in Δt ×]) Ĉ exp([φ ×])     (left factor to first order, then renormalised)

Covariance (:func:`propagate`), the error model of :mod:`.gyro_bias_ekf_model` over T with
A = C_nm M held::

    F_ψψ = exp(−[ω_in T ×]),  F_ψb = ½T²[ω_in ×]A − T A,  F_ee = e^{−T/τ_e} I
    Q_ψψ = A N Aᵀ T + A Q_b Aᵀ T³/3,  Q_ψb = −A Q_b T²/2,  Q_bb = Q_b T,  Q_ee = σ_e²(1 − e^{−2T/τ_e})
    P ← sym(F P Fᵀ + Q),  sym(X) = ½(X + Xᵀ)

Measurement update (:func:`joseph_update3`), three components, gate d² ≤ γ::

    y = z − H x,  S = sym(H P Hᵀ + R),  d² = yᵀ S⁻¹ y,  K = P Hᵀ S⁻¹
    x ← x + K y,  P ← sym((I − K H) P (I − K H)ᵀ + K R Kᵀ)       (Joseph form)
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.maths.quat_kernels import quat_from_euler321, quat_from_rotation_vector, quat_mul
from gimbal_kinematics.maths.rotation_kernels import rotation_vector_to_dcm

#: |cos θm| below which eq. 4 is singular (the core's ``_SINGULAR_COS``).
SINGULAR_COS = 1e-3

#: The error state x = [ψ, δb, e] of :mod:`.gyro_bias_ekf_model`: slices of x and of P's rows
#: and columns, their first indices, and the state counts without and with the INS errors.
PSI, BIAS, INS_ERROR = slice(0, 3), slice(3, 6), slice(6, 9)
PSI_0, BIAS_0, INS_ERROR_0 = 0, 3, 6
N_STATES_BASE, N_STATES_INS = 6, 9


@njit(cache=True)
def mat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a b, summed in index order."""
    n, m, p = a.shape[0], a.shape[1], b.shape[1]
    out = np.zeros((n, p))
    for i in range(n):
        for j in range(p):
            s = 0.0
            for k in range(m):
                s += a[i, k] * b[k, j]
            out[i, j] = s
    return out


@njit(cache=True)
def mat_mul_t(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a bᵀ, summed in index order."""
    return mat_mul(a, b.T)


@njit(cache=True)
def symmetrize(a: np.ndarray) -> np.ndarray:
    """½(a + aᵀ)."""
    return 0.5 * (a + a.T)


@njit(cache=True)
def measured_quat_nm(q_nb: tuple, a0: float, a1: float, a2: float) -> tuple:
    """(x, y, z, w) of C_nm = C_nb C_bm(ψt, ψm, θm): q_nb ⊗ q_z(ψt + ψm) ⊗ q_y(θm)."""
    ha, he = 0.5 * (a0 + a1), 0.5 * a2
    ca, sa, ce, se = math.cos(ha), math.sin(ha), math.cos(he), math.sin(he)
    return quat_mul(q_nb, (-sa * se, ca * se, sa * ce, ca * ce))


@njit(cache=True)
def ins_error_jacobian(pitch: float, yaw: float) -> np.ndarray:
    """J_e (3, 3) = [C_nb e1, rot3(ψ)ᵀ e2, e3]: n-frame rotation per Euler-angle error."""
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cp * cy, -sy, 0.0], [cp * sy, cy, 0.0], [-sp, 0.0, 1.0]])


@njit(cache=True)
def encoder_error_jacobian(q_nb: tuple, q_nm: tuple) -> np.ndarray:
    """(3, 3) = [u, u, v], u = C_nb e3 (turret and azimuth), v = C_nm e2 (elevation)."""
    bx, by, bz, bw = q_nb
    mx, my, mz, mw = q_nm
    u0, u1, u2 = 2.0 * (bx * bz + by * bw), 2.0 * (by * bz - bx * bw), 1.0 - 2.0 * (bx * bx + by * by)
    v0, v1, v2 = 2.0 * (mx * my - mz * mw), 1.0 - 2.0 * (mx * mx + mz * mz), 2.0 * (my * mz + mx * mw)
    return np.array([[u0, u0, v0], [u1, u1, v1], [u2, u2, v2]])


@njit(cache=True)
def measurement(euler: tuple, angles: tuple) -> tuple:
    """(q_meas, J_e, J_enc) of an INS attitude read as 3-2-1 ``euler`` and the encoder
    ``angles`` (ψt, ψm, θm) (:mod:`.gyro_bias_ekf_model`, "Measurement")."""
    q_nb = quat_from_euler321(euler[0], euler[1], euler[2])
    q_meas = measured_quat_nm(q_nb, angles[0], angles[1], angles[2])
    return q_meas, ins_error_jacobian(euler[1], euler[2]), encoder_error_jacobian(q_nb, q_meas)


@njit(cache=True)
def mechanize(q: tuple, w0: tuple, w1: tuple, dt: float, win: tuple) -> tuple:
    """Ĉ(n,m) as (x, y, z, w) after one gyro interval ``dt`` [s] from the bias-corrected rates
    ``w0``, ``w1`` (p, q, r) [rad/s] at its ends, ω_in^n = ``win`` (module docstring)."""
    p0, q0, r0 = w0
    p1, q1, r1 = w1
    h = 0.5 * dt
    k = dt * dt / 12.0
    phx = h * (p0 + p1) + k * (q0 * r1 - r0 * q1)
    phy = h * (q0 + q1) + k * (r0 * p1 - p0 * r1)
    phz = h * (r0 + r1) + k * (p0 * q1 - q0 * p1)
    x, y, z, w = quat_mul(q, quat_from_rotation_vector(phx, phy, phz))
    # left product exp(−[ω_in Δt×]) (|ω_in Δt| ~ 1e-7: first order is exact to 1e-21)
    ex, ey, ez = -h * win[0], -h * win[1], -h * win[2]
    x, y, z, w = (x + ey * z - ez * y + ex * w, y - ex * z + ez * x + ey * w,
                  z + ex * y - ey * x + ez * w, w - ex * x - ey * y - ez * z)
    n = 1.5 - 0.5 * (x * x + y * y + z * z + w * w)  # first-order renormalisation
    return (x * n, y * n, z * n, w * n)


@njit(cache=True)
def a_matrix(q: tuple, ct: float, st: float) -> np.ndarray:
    """C_nm M (3, 3) at the estimate ``q`` and cos, sin θm (|cos θm| floored at SINGULAR_COS)."""
    ct = ct if abs(ct) >= SINGULAR_COS else math.copysign(SINGULAR_COS, ct)
    x, y, z, w = q
    c00, c10, c20 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)
    c02, c12, c22 = 2.0 * (x * z + y * w), 2.0 * (y * z - x * w), 1.0 - 2.0 * (x * x + y * y)
    k = st / ct
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = c00 / ct, 2.0 * (x * y - z * w), c02 - k * c00
    out[1, 0], out[1, 1], out[1, 2] = c10 / ct, 1.0 - 2.0 * (x * x + z * z), c12 - k * c10
    out[2, 0], out[2, 1], out[2, 2] = c20 / ct, 2.0 * (y * z + x * w), c22 - k * c20
    return out


@njit(cache=True)
def propagate(P: np.ndarray, A: np.ndarray, T: float, w: np.ndarray, n_psd: np.ndarray, qb_psd: np.ndarray,
              pe_var: np.ndarray, tau_e: float) -> tuple:
    """(P over T, F_ee) with the error model (module docstring); P (n, n), n = 6 or 9
    (``pe_var`` (3,) is used with n = 9 only); ``tau_e`` inf: constant INS errors."""
    n = P.shape[0]
    F = np.eye(n)
    F[PSI, PSI] = rotation_vector_to_dcm(-T * w[0], -T * w[1], -T * w[2])
    Wx = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    F[PSI, BIAS] = (0.5 * T * T) * mat_mul(Wx, A) - T * A
    Q = np.zeros((n, n))
    AN = np.empty((3, 3))
    AQb = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            AN[i, j] = A[i, j] * (n_psd[j] * T) + A[i, j] * qb_psd[j] * (T ** 3 / 3.0)
            AQb[i, j] = A[i, j] * qb_psd[j]
    Q[PSI, PSI] = mat_mul_t(AN, A)
    for i in range(3):
        for j in range(3):
            Q[PSI_0 + i, BIAS_0 + j] = AQb[i, j] * (-0.5 * T * T)
            Q[BIAS_0 + j, PSI_0 + i] = Q[PSI_0 + i, BIAS_0 + j]
        Q[BIAS_0 + i, BIAS_0 + i] = qb_psd[i] * T
    f_e = 1.0
    if n == N_STATES_INS:
        decaying = not math.isinf(tau_e)
        f_e = math.exp(-T / tau_e) if decaying else 1.0
        for i in range(3):
            F[INS_ERROR_0 + i, INS_ERROR_0 + i] = f_e
            Q[INS_ERROR_0 + i, INS_ERROR_0 + i] = pe_var[i] * (-math.expm1(-2.0 * T / tau_e) if decaying else 0.0)
    return symmetrize(mat_mul_t(mat_mul(F, P), F) + Q), f_e


@njit(cache=True)
def measurement_cov(Jenc: np.ndarray, Je: np.ndarray, enc_var: float, floor_var: float, pe_var: np.ndarray,
                    white_ins: bool) -> np.ndarray:
    """R (3, 3) = σ_enc² J_enc J_encᵀ + σ_floor² I, plus J_e diag(σ_e²) J_eᵀ when the INS
    errors are white (no INS-error states)."""
    R = enc_var * mat_mul_t(Jenc, Jenc)
    for i in range(3):
        R[i, i] += floor_var
    if white_ins:
        JeP = Je * pe_var.reshape(1, 3)
        R = R + mat_mul_t(JeP, Je)
    return R


@njit(cache=True)
def align_cov(n: int, R: np.ndarray, Je: np.ndarray, pe_var: np.ndarray, P_bb: np.ndarray) -> np.ndarray:
    """P (n, n) at an alignment Ĉ = C_meas: P_ψψ = R (+ J_e P_e J_eᵀ, P_ψe = −J_e P_e, P_ee =
    P_e with the INS-error states), P_bb given."""
    P = np.zeros((n, n))
    P[BIAS, BIAS] = P_bb
    if n == N_STATES_INS:
        JeP = Je * pe_var.reshape(1, 3)
        P[PSI, PSI] = mat_mul_t(JeP, Je) + R
        for i in range(3):
            for j in range(3):
                P[PSI_0 + i, INS_ERROR_0 + j] = -JeP[i, j]
                P[INS_ERROR_0 + j, PSI_0 + i] = -JeP[i, j]
            P[INS_ERROR_0 + i, INS_ERROR_0 + i] = pe_var[i]
    else:
        P[PSI, PSI] = R
    return symmetrize(P)


@njit(cache=True)
def _inv3(S: np.ndarray) -> np.ndarray:
    """S⁻¹ of a (3, 3) by its adjugate."""
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 0], S[1, 1], S[1, 2]
    g, h, i = S[2, 0], S[2, 1], S[2, 2]
    c0, c1, c2 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * c0 + b * c1 + c * c2
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = c0 / det, (c * h - b * i) / det, (b * f - c * e) / det
    out[1, 0], out[1, 1], out[1, 2] = c1 / det, (a * i - c * g) / det, (c * d - a * f) / det
    out[2, 0], out[2, 1], out[2, 2] = c2 / det, (b * g - a * h) / det, (a * e - b * d) / det
    return out


@njit(cache=True)
def joseph_update3(x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray,
                   gate: float) -> tuple:
    """(accepted, x, P, y, d²) of a three-component update in Joseph form (module
    docstring); rejected (d² beyond ``gate`` or NaN): x and P returned unchanged."""
    n = x.shape[0]
    y = np.empty(3)
    for i in range(3):
        s = 0.0
        for k in range(n):
            s += H[i, k] * x[k]
        y[i] = z[i] - s
    PHt = mat_mul_t(P, H)
    S = symmetrize(mat_mul(H, PHt) + R)
    S_inv = _inv3(S)
    d2 = 0.0
    for i in range(3):
        for j in range(3):
            d2 += y[i] * S_inv[i, j] * y[j]
    if not d2 <= gate:
        return False, x.copy(), P.copy(), y, d2
    K = mat_mul(PHt, S_inv)
    I_KH = np.eye(n) - mat_mul(K, H)
    P_new = symmetrize(mat_mul_t(mat_mul(I_KH, P), I_KH) + mat_mul_t(mat_mul(K, R), K))
    x_new = x.copy()
    for i in range(n):
        for j in range(3):
            x_new[i] += K[i, j] * y[j]
    return True, x_new, P_new, y, d2
