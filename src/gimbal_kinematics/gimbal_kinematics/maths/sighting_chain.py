"""The two-axis sighting chain of paper 1, section 2 (docs/spec.md section 2).

Frames: navigation ``n`` (NED) -> host body ``b`` (3-2-1 Euler φ, θ, ψ) -> revolving base
(turret) ``t`` (azimuth ψt about b-z) -> outer gimbal ``a`` (azimuth ψm about t-z) -> inner
gimbal ``m`` (elevation θm about a-y). The line of sight (LOS) is the m-frame x axis.

Following the paper, ``n`` is treated as inertial in the chain's rate equations: the body
rates (p, q, r) are the host's inertial rates as an INS gyro triad measures them. Earth and
transport rate enter only the attitude mechanization of the estimators.

Derivation used throughout (a child frame c turning about its unit axis ``u`` by angle δ
relative to its parent p, ``C_cp = rot_u(δ)``):

    ω_c = C_cp ω_p + δ̇ u
    α_c = C_cp α_p + δ̈ u + (C_cp ω_p) × (δ̇ u)

where ω and α are inertial angular velocity and acceleration resolved in the frame named.
The last term is the transport derivative of ``C_cp ω_p`` (``Ċ_cp = -skew(δ̇ u) C_cp``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .rotations import euler321_to_dcm, rot2, rot3

_E2 = np.array([0.0, 1.0, 0.0])
_E3 = np.array([0.0, 0.0, 1.0])

#: |cos θm| below which the elevation gimbal is treated as at ±90°, where the LOS azimuth
#: axis and the roll axis align and the two-axis gyro cannot resolve the azimuth rate.
ELEVATION_SINGULAR_COS = 1e-6


def dcm_nb(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``C_nb``: body to navigation, from the host's 3-2-1 Euler angles [rad]."""
    return euler321_to_dcm(roll, pitch, yaw)


def dcm_bt(psi_t: float) -> np.ndarray:
    """``C_bt``: turret to body, turret azimuth ψt [rad] about b-z."""
    return rot3(psi_t).T


def dcm_ta(psi_m: float) -> np.ndarray:
    """``C_ta``: outer gimbal to turret, gimbal azimuth ψm [rad] about t-z."""
    return rot3(psi_m).T


def dcm_am(theta_m: float) -> np.ndarray:
    """``C_am``: inner gimbal to outer gimbal, elevation θm [rad] about a-y."""
    return rot2(theta_m).T


def dcm_nm(euler: np.ndarray, psi_t: float, psi_m: float, theta_m: float) -> np.ndarray:
    """``C_nm``: inner gimbal (LOS) frame to navigation; ``euler`` = (φ, θ, ψ) [rad]."""
    return dcm_nb(*euler) @ dcm_bt(psi_t) @ dcm_ta(psi_m) @ dcm_am(theta_m)


def dcm_bm(psi_t: float, psi_m: float, theta_m: float) -> np.ndarray:
    """``C_bm``: inner gimbal to body, from the three encoder angles [rad]."""
    return dcm_bt(psi_t) @ dcm_ta(psi_m) @ dcm_am(theta_m)


def los_unit_vector_n(C_nm: np.ndarray) -> np.ndarray:
    """LOS unit vector resolved in n (the m-frame x axis); shape (3,)."""
    return np.asarray(C_nm)[:, 0].copy()


def los_azimuth_elevation(C_nm: np.ndarray) -> tuple[float, float]:
    """LOS (azimuth, elevation) [rad] in the NED frame.

    Azimuth is measured from north towards east in (-π, π]; elevation is positive above
    the horizontal (NED z points down, hence the sign).
    """
    los = los_unit_vector_n(C_nm)
    return math.atan2(los[1], los[0]), math.atan2(-los[2], math.hypot(los[0], los[1]))


@dataclass(frozen=True)
class ChainRates:
    """Inertial angular velocity [rad/s] and acceleration [rad/s²] of t, a, m; each (3,),
    resolved in its own frame (``omega_t_t`` is ω of t resolved in t)."""

    omega_t_t: np.ndarray
    alpha_t_t: np.ndarray
    omega_a_a: np.ndarray
    alpha_a_a: np.ndarray
    omega_m_m: np.ndarray
    alpha_m_m: np.ndarray


def _child_rates(
    C_cp: np.ndarray, omega_p: np.ndarray, alpha_p: np.ndarray, axis: np.ndarray,
    rate: float, accel: float,
) -> tuple[np.ndarray, np.ndarray]:
    carried = C_cp @ omega_p
    joint = rate * axis
    return carried + joint, C_cp @ alpha_p + accel * axis + np.cross(carried, joint)


def chain_rates(
    omega_b_b: np.ndarray,
    alpha_b_b: np.ndarray,
    joint_angles: np.ndarray,
    joint_rates: np.ndarray,
    joint_accels: np.ndarray,
) -> ChainRates:
    """Inertial rates and accelerations of the turret, outer and inner gimbal frames.

    ``omega_b_b``/``alpha_b_b``: host inertial rate [rad/s] and acceleration [rad/s²] in b.
    ``joint_angles``/``joint_rates``/``joint_accels``: (ψt, ψm, θm) and their first and
    second derivatives [rad, rad/s, rad/s²]. All inputs shape (3,).
    """
    psi_t, psi_m, theta_m = joint_angles
    d_t, d_m, d_e = joint_rates
    dd_t, dd_m, dd_e = joint_accels
    omega_b_b = np.asarray(omega_b_b, dtype=float)
    alpha_b_b = np.asarray(alpha_b_b, dtype=float)
    w_t, a_t = _child_rates(rot3(psi_t), omega_b_b, alpha_b_b, _E3, d_t, dd_t)
    w_a, a_a = _child_rates(rot3(psi_m), w_t, a_t, _E3, d_m, dd_m)
    w_m, a_m = _child_rates(rot2(theta_m), w_a, a_a, _E2, d_e, dd_e)
    return ChainRates(w_t, a_t, w_a, a_a, w_m, a_m)


def omega_m_m(omega_b_b: np.ndarray, joint_angles: np.ndarray, joint_rates: np.ndarray) -> np.ndarray:
    """Inertial rate of the inner gimbal in m [rad/s] (docs/spec.md §2):
    ω_m = C_mb ω_b + C_mt [0, 0, ψ̇t] + C_ma [0, 0, ψ̇m] + [0, θ̇m, 0]; shape (3,)."""
    zero = np.zeros(3)
    return chain_rates(omega_b_b, zero, joint_angles, joint_rates, zero).omega_m_m


def _turret_rate_in_a(
    omega_b_b: np.ndarray, psi_t: float, psi_t_dot: float, psi_m: float
) -> np.ndarray:
    """Inertial rate of the turret resolved in the outer-gimbal frame a [rad/s]."""
    return rot3(psi_m) @ (rot3(psi_t) @ np.asarray(omega_b_b, dtype=float) + psi_t_dot * _E3)


def _elevation_cos_sin(theta_m: float) -> tuple[float, float]:
    c, s = math.cos(theta_m), math.sin(theta_m)
    if abs(c) < ELEVATION_SINGULAR_COS:
        raise ValueError(
            f"elevation θm = {math.degrees(theta_m):.6f}° is at ±90°: the gimbal roll and "
            "azimuth axes align, so the two-axis gyro cannot resolve the azimuth rate"
        )
    return c, s


def reconstruct_roll_rate(
    omega_b_b: np.ndarray, r_m: float, psi_t: float, psi_t_dot: float, psi_m: float,
    theta_m: float,
) -> tuple[float, float]:
    """Paper 1 eq. 4: inner-gimbal roll rate p_m and gimbal azimuth rate ψ̇m [rad/s].

    A two-axis gyro on the inner gimbal measures only q_m and r_m. With w = ω of the turret
    resolved in a (from the INS body rates, ψt, ψ̇t, ψm) and c, s = cos θm, sin θm:

        p_m = c w1 - s (w3 + ψ̇m),   r_m = s w1 + c (w3 + ψ̇m)

    Eliminating the unmeasured ψ̇m with the measured r_m gives

        p_m = (w1 - s r_m) / c,      ψ̇m = (r_m - s w1) / c - w3.

    Raises ``ValueError`` at θm = ±90°.
    """
    c, s = _elevation_cos_sin(theta_m)
    w = _turret_rate_in_a(omega_b_b, psi_t, psi_t_dot, psi_m)
    return (w[0] - s * r_m) / c, (r_m - s * w[0]) / c - w[2]


def task_to_joint_rates(
    q_md: float, r_md: float, omega_b_b: np.ndarray, psi_t: float, psi_t_dot: float,
    psi_m: float, theta_m: float,
) -> tuple[float, float]:
    """Joint rates (ψ̇md, θ̇md) [rad/s] that realise a commanded inertial LOS rate.

    Paper 1 section 5 stabilizes in the task frame (q_md = r_md = 0 holds the LOS
    inertially still) but applies torques at the joints. From the chain,
    q_m = w2 + θ̇m and r_m = s w1 + c (w3 + ψ̇m), so

        θ̇md = q_md - w2,   ψ̇md = (r_md - s w1) / c - w3.

    Raises ``ValueError`` at θm = ±90°.
    """
    c, s = _elevation_cos_sin(theta_m)
    w = _turret_rate_in_a(omega_b_b, psi_t, psi_t_dot, psi_m)
    return (r_md - s * w[0]) / c - w[2], q_md - w[1]
