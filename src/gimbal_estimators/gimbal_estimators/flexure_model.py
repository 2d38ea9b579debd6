"""The flexure filter's model (:mod:`.flexure_kf` runs it): the attitude-matching
observation and the 18-state dynamics of paper 5.

Observation (paper 5 eqs. 3-6, re-derived)
------------------------------------------
The flexure φ is the small rotation from b1 to b2, ``C_b1b2 = exp([φ×]) ≈ I + [φ×]``. A gyro
bias ε makes the integrated attitude depart as ``Ĉ_ib = (I + [e×]) C_ib`` with
``ė = C_ib ε`` (e resolved in the i-frame). Because i1 and i2 differ by the initial flexure
φ0 (``C_i2i1 ≈ I − [φ0×]``) and the product of the two integrated DCMs treats them as one
frame,

    M = Ĉ_i1b1ᵀ Ĉ_i2b2 ≈ I + [(φ − A θ_d)×],    A = Ĉ_i1b1ᵀ (= C_b1i1),
    θ_d = φ0 + e1 − e2,    θ̇_d = Ĉ_i1b1 (ε1 − ε2),    θ_d(t0) = φ(t0),

so ``Z = small_angles(M) = φ − A θ_d`` (eq. 5): the flexure plus the 'relative attitude'
θ_d of the estimated i1 with respect to i2, which starts at the initial flexure and is
driven by the bias *difference* only (eq. 6), rotated into the i-frame. Writing
φ = Φ + θ (quasi-static + dynamic), ``H = [I 0 I 0 −A 0]`` (eq. 17). Exactly,
``M = exp(−[u×]) exp([φ×])`` with u = A θ_d, whose logarithm adds ``−½ u×φ`` (BCH):
up to tens of arcseconds when a 0.5° flexure is not parallel to θ_d, and modulated by the
ship's rocking like the signal itself. The filter therefore predicts Z with that term
(:func:`predicted_observation`, an EKF innovation) and keeps the paper's H for the gain
(its missing part is O(|φ|) ≈ 1 % of H).
The i-frame is inertial, so A carries the ship's rocking and the earth's rotation; that
modulation is what separates θ_d (and hence the absolute flexure) from Φ + θ.

State (18) and dynamics, one nominal step T = ``filter_period_s``
-----------------------------------------------------------------
``X = [Φ_k, Φ_{k−1}, θ_k, θ_{k−1}, θ_d, ε1−ε2]``, 3 each (roll, pitch, yaw; ε in b1 axes).

* quasi-static, ``random_constant``: ``Φ_k = Φ_{k−1} + w``, Var w = q_c T (q_c from
  ``qs_rw_arcsec_rt_s``, kept tiny so the model is the conventional random constant);
  ``random_walk_rate`` (eq. 10): ``Φ_k = 2Φ_{k−1} − Φ_{k−2} + e``: the sampled form of
  Φ̈ = w with PSD q_r (``qs_rate_rw_arcsec_s_rt_s``²); Var e = q_r T³ matches the exact
  second difference's low-frequency spectrum (its variance is ⅔ q_r T³, lag-1 ⅙ q_r T³).
* dynamic (eq. 12): the second-order Gauss-Markov θ̈ + 2βθ̇ + ω0²θ = w, ω0² = β² + λ²,
  sampled as AR(2) with the exact poles z = exp((−β ± jλ)T):
  ``θ_k = 2r cos(λT) θ_{k−1} − r² θ_{k−2} + e``, r = e^{−βT}, and Var e chosen so the
  stationary variance is exactly σ²: ``σ_e² = σ²(1−r²)((1−r²)² + 4r² sin²λT)/(1+r²)``.
  Its autocorrelation then equals the continuous ``e^{−βτ}(cos λτ + (β/λ) sin λτ)`` up to
  O(T²) in the sine coefficient.
* relative attitude: ``θ_d,k = θ_d,k−1 + C̄ Δt (ε1−ε2) + n``, C̄ the mean of Ĉ_i1b1 over
  the interval, Var n = (N1² + N2²) Δt from the units' angle random walk.
* bias difference: random walk (eq. 11).
"""
from __future__ import annotations

import math

import numpy as np

#: Slices of the state vector.
PHI_K, PHI_K1, THETA_K, THETA_K1, THETA_D, EPS = (slice(3 * i, 3 * i + 3) for i in range(6))
N_STATES = EPS.stop


def ar2_coefficients(beta: float, freq: float, sigma: float, dt: float) -> tuple[float, float, float]:
    """``(a1, a2, var_e)`` of the AR(2) ``θ_k = a1 θ_{k−1} + a2 θ_{k−2} + e`` sampling the
    second-order Gauss-Markov process (decay β [1/s] > 0, damped frequency λ [rad/s] >= 0,
    stationary RMS σ) at step ``dt`` [s]: exact poles, exact stationary variance σ²."""
    r2 = math.exp(-2.0 * beta * dt)
    one_minus_r2 = -math.expm1(-2.0 * beta * dt)
    r = math.sqrt(r2)
    a1 = 2.0 * r * math.cos(freq * dt)
    a2 = -r2
    s = math.sin(freq * dt)
    var_e = sigma * sigma * one_minus_r2 * (one_minus_r2 * one_minus_r2 + 4.0 * r2 * s * s) / (1.0 + r2)
    return a1, a2, var_e


def ar2_autocorrelation(a1: float, a2: float, lags: int) -> np.ndarray:
    """Normalised autocorrelation ρ_0..ρ_lags of a stationary AR(2) (Yule-Walker recursion)."""
    rho = np.empty(lags + 1)
    rho[0] = 1.0
    if lags >= 1:
        rho[1] = a1 / (1.0 - a2)
    for k in range(2, lags + 1):
        rho[k] = a1 * rho[k - 1] + a2 * rho[k - 2]
    return rho


def match_attitudes(C_i1b1: np.ndarray, C_i2b2: np.ndarray) -> np.ndarray:
    """Attitude-matching observation ``Z = small_angles(Ĉ_i1b1ᵀ Ĉ_i2b2)`` [rad], (3,)
    (``vee`` of the antisymmetric part, as :func:`gimbal_kinematics.maths.rotations.small_angles_from_dcm`
    without its orthonormality check). Inputs (3, 3)."""
    M = C_i1b1.T @ C_i2b2
    return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])


def observation_matrix(C_i1b1: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``H = [I 0 I 0 −A 0]`` (3, 18) with ``A = Ĉ_i1b1ᵀ`` (eq. 17); fills ``out`` if given."""
    H = np.zeros((3, N_STATES)) if out is None else out
    if out is None:
        H[:, PHI_K] = np.eye(3)
        H[:, THETA_K] = np.eye(3)
    H[:, THETA_D] = -C_i1b1.T
    return H


def predicted_observation(C_i1b1: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``h(X) = φ − u − ½ u×φ`` [rad], (3,), with φ = Φ_k + θ_k and u = A θ_d: the
    attitude-matching observation to second order (Baker-Campbell-Hausdorff of
    ``exp(−[u×]) exp([φ×])``); the paper's first-order form drops ``½ u×φ``, which reaches
    several arcseconds once the flexure is a few tenths of a degree."""
    u = C_i1b1.T @ x[THETA_D]
    phi = x[PHI_K] + x[THETA_K]
    p0, p1, p2 = float(phi[0]), float(phi[1]), float(phi[2])
    u0, u1, u2 = float(u[0]), float(u[1]), float(u[2])
    return np.array([
        p0 - u0 - 0.5 * (u1 * p2 - u2 * p1),
        p1 - u1 - 0.5 * (u2 * p0 - u0 * p2),
        p2 - u2 - 0.5 * (u0 * p1 - u1 * p0),
    ])
