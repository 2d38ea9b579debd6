"""The gyro-bias EKF's model (:mod:`.gyro_bias_ekf` runs it): the measured attitude C(n,m)
from the INS Euler angles and the encoders, its error Jacobians, the roll-rate error matrix
M and the discretised error model (F, Q).

State and error model
---------------------
Error state ``x = [ψ (3), δb (3), e (3)]`` (the last block only with ``ins_error_states``):

* ψ: attitude error resolved in n, ``Ĉ = (I − [ψ×]) C`` (so
  ``ψ = small_angles_from_dcm(C Ĉᵀ)``, as in :mod:`gimbal_kinematics.maths.rotations`);
  reset to zero after each update by ``Ĉ ← exp([ψ̂×]) Ĉ``.
* δb = b − b̂, b = (b_x, b_q, b_r) [rad/s]. b_q, b_r are the gyro biases. There is no roll
  gyro: b_x is the error of w1 (the INS-rate part of eq. 4), i.e. the INS gyro bias
  projected on the outer-gimbal x axis, ``b_x = cos(ψt+ψm) b_p + sin(ψt+ψm) b_q^INS``.
  The r-gyro bias reaches the reconstructed roll rate through eq. 4 itself, so the
  roll-rate error is δp_m = (δb_x − sin θm δb_r)/cos θm; this coupling is in F (matrix M
  below) rather than lumped into an independent "x bias", which would lose the link to b_r.
* e = (e_φ, e_θ, e_ψ): the INS Euler-angle errors (see "INS errors").

With δω = ω̂ − ω = M (δb + n), ``M = [[1/c, 0, −s/c], [0, 1, 0], [0, 0, 1]]`` (c, s = cos,
sin θm), n = white rate noise (INS ARW on w1; gyro ARW on q, r), the linear error model is

    ψ̇ = −ω_in^n × ψ − C_nm M (δb + n)
    ḃ = w_b                     (lumped bias: random walk, see below)
    ė = −e / τ_e + w_e          (first-order Gauss-Markov per Euler angle)

discretised once per covariance step T (each INS update, at least every
``covariance_period_s``) with Ā = ½(C M|_{t0} + C M|_{t1}):
Φ_ψψ = exp(−[ω_in T ×]), Φ_ψb = −(I − ½[ω_in×]T) Ā T, Φ_ee = e^{−T/τ_e} I;
Q_ψψ = Ā N Āᵀ T + Ā Q_b Āᵀ T³/3, Q_ψb = −Ā Q_b T²/2, Q_bb = Q_b T, Q_ee = σ_e²(1 − e^{−2T/τ_e}).

Lumped bias model (paper 1 eq. 17–21). The truth is a random constant (the turn-on bias)
plus a first-order Gauss-Markov bias instability (σ_gm, τ). One state per axis cannot carry
both exactly, so the lumped state is a random walk whose PSD ``q_b = 2 σ_gm² / τ`` matches
the Gauss-Markov increments at lags ≪ τ (var[b(t+L) − b(t)] = 2σ_gm²(1 − e^{−L/τ}) ≈ q_b L);
its prior 1σ ``*_bias_sigma_deg_h`` covers turn-on bias + instability. A lumped
Gauss-Markov state would instead pull the large constant bias towards zero. The filter
memory (about 15 s on paper 1's numbers, 70 s at τ = 300 s) is well below τ, where the two
models agree, which is what keeps the bias NEES consistent.

Measurement
-----------
C(n,m)_meas = C_nb(INS Euler) C_bm(encoders) (``sighting_chain.dcm_nb``, ``dcm_bm``, built
here as the equivalent quaternion product, :func:`measured_quat_nm`),
z = log(C_meas Ĉᵀ) ≈ ψ + δα, δα the n-frame rotation error of C_meas. To first order

    δα = J_e e + u (ε_t + ε_m) + v ε_θ,
    J_e = [C_nb e1, rot3(ψ)ᵀ e2, e3],  u = C_nb e3,  v = C_nm e2,

(ε_t, ε_m, ε_θ the encoder errors; turret and gimbal azimuth turn about the same axis u).
H = [I, 0, J_e], R = σ_enc² (2 u uᵀ + v vᵀ) + σ_floor² I.

INS errors. Paper 1 treats the INS angles as white noise. They are not: the simulated INS (and a
real one) has slowly varying errors (Gauss-Markov, τ = 300 s, 0.05°/0.05°/0.2° RMS). Fused
at 100 Hz as white noise they make the filter believe the attitude to ~0.005° while the
true error stays ~0.1°, and the slow INS wander is read as gyro bias with too much
confidence: on 16 runs × 60 s of paper 1's scenario the 6-state NEES averaged 866 (6
expected) and the (b_q, b_r) NEES 6.3 (2 expected; b_r error 2.3σ RMS). With
``ins_error_states=True`` (default) they are three Gauss-Markov states (above), so
H = [I, 0, J_e]; the filter then knows the gimbal attitude only as well as the INS does,
and over 20 runs × 120 s the NEES averages 5.75 (6 states) and 1.89 (biases).
``ins_error_states=False`` is paper 1's form: H = [I 0], R = J_e diag(σ_e²) J_eᵀ + R_enc
(white); the bias accuracy is about the same, only its stated σ is wrong.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, quat_from_euler321

from . import gyro_bias_ekf_kernels as kernels
from .gyro_bias_ekf_kernels import BIAS, INS_ERROR, N_STATES_BASE, N_STATES_INS, PSI

#: ψ and δb together: the whole state of the filter without INS error states (the slices
#: PSI, BIAS, INS_ERROR of x = [ψ, δb, e] and the state counts are the kernels').
PSI_BIAS = slice(PSI.start, BIAS.stop)
#: (δb_q, δb_r), the gimbal gyro's own biases: δb without the INS-rate channel's δb_x.
GYRO_BIAS = slice(BIAS.start + 1, BIAS.stop)


def quat_nb_from_euler(euler: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of C_nb = ``sighting_chain.dcm_nb(φ, θ, ψ)`` (3-2-1 Euler angles [rad])."""
    return quat_from_euler321(euler[0], euler[1], euler[2])


def measured_quat_nm(q_nb: Sequence[float], angles: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of C_nm = C_nb ``sighting_chain.dcm_bm(ψt, ψm, θm)``; C_bm is a turn of
    ψt + ψm about z followed by θm about y, so q_bm = q_z(ψt + ψm) ⊗ q_y(θm)
    (:func:`.gyro_bias_ekf_kernels.measured_quat_nm`)."""
    return kernels.measured_quat_nm(tuple(q_nb), float(angles[0]), float(angles[1]), float(angles[2]))


def ins_error_jacobian(euler: Sequence[float]) -> np.ndarray:
    """J_e (3, 3): n-frame rotation δα of C_nb per Euler-angle error (δφ, δθ, δψ) [rad/rad],
    i.e. C_nb(euler + δ) ≈ (I + [J_e δ ×]) C_nb(euler) (:func:`.gyro_bias_ekf_kernels.ins_error_jacobian`)."""
    return kernels.ins_error_jacobian(float(euler[1]), float(euler[2]))


def encoder_error_jacobian(q_nb: Sequence[float], q_nm: Sequence[float]) -> np.ndarray:
    """(3, 3): n-frame rotation of C_nm per encoder error (ε_t, ε_m, ε_θ) [rad/rad], from the
    (x, y, z, w) quaternions of C_nb and C_nm: turret and gimbal azimuth turn about
    u = C_nb e3, the elevation about v = C_nm e2 (:func:`.gyro_bias_ekf_kernels.encoder_error_jacobian`)."""
    return kernels.encoder_error_jacobian(tuple(float(v) for v in q_nb), tuple(float(v) for v in q_nm))


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
    n = N_STATES_BASE if pe_var is None else N_STATES_INS
    F = np.eye(n)
    w = np.asarray(omega_in_n, dtype=float)
    F[PSI, PSI] = dcm_from_rotation_vector(-T * w)
    # −∫ exp(−[ω_in×](T−s)) A ds, to second order in |ω_in| T (~1e-6).
    wx, wy, wz = w
    Wx = np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
    F[PSI, BIAS] = (0.5 * T * T) * (Wx @ A) - T * A
    Q = np.zeros((n, n))
    AQb = A * qb_psd  # A diag(q): the densities are diagonal
    Q[PSI, PSI] = (A * (np.asarray(n_psd) * T) + AQb * (T**3 / 3.0)) @ A.T
    Q[PSI, BIAS] = AQb * (-0.5 * T * T)
    Q[BIAS, PSI] = Q[PSI, BIAS].T
    Q[BIAS, BIAS] = np.diag(np.asarray(qb_psd) * T)
    if pe_var is not None:
        decaying = not math.isinf(tau_e)
        F[INS_ERROR, INS_ERROR] *= math.exp(-T / tau_e) if decaying else 1.0
        Q[INS_ERROR, INS_ERROR] = np.diag(np.asarray(pe_var) * (-math.expm1(-2.0 * T / tau_e) if decaying else 0.0))
    return F, Q
