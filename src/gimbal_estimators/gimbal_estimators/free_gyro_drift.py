"""The drifting free gyro's error terms for the linear error model
(:mod:`.free_gyro_error_model`, paper 4's closing section): the variance of an integrated
first-order Gauss–Markov drift rate, the effective time of an integrated rate sensor's random
walk averaged over a fix window, and the gimbal-lock suppression's precession along a known
attitude history. Closed forms and sums, SI units (rad, rad/s, s).
"""
from __future__ import annotations

import math

import numpy as np

from gimbal_kinematics.maths.free_gyro import Vector3, unit_vector
from gimbal_kinematics.maths.validate import nonneg_finite, positive


def gauss_markov_integral_variance(sigma: float, tau_s: float, t: float) -> float:
    """Variance [rad²] of ∫₀ᵗ x dt of a stationary first-order Gauss–Markov rate x with σ
    ``sigma`` [rad/s] and correlation time ``tau_s`` [s]: 2 σ² τ² (t/τ − 1 + e^{−t/τ})."""
    s, tau, t = nonneg_finite("sigma", sigma), positive("tau_s", tau_s), nonneg_finite("t", t)
    r = t / tau
    # t/τ − 1 + e^{−t/τ}, series for small t/τ (cancellation)
    g = r * r / 2.0 - r ** 3 / 6.0 + r ** 4 / 24.0 if r < 1e-3 else r - 1.0 + math.exp(-r)
    return 2.0 * s * s * tau * tau * g


def random_walk_window_time(t_first: float, samples: int, interval_s: float) -> float:
    """The random walk's effective time [s] of the mean of ``samples`` read-outs
    ``interval_s`` apart from ``t_first`` [s] (its variance over N²): t_first + Δt (n − 1)(2n − 1)/(6n),
    from Σᵢⱼ min(tᵢ, tⱼ)/n²."""
    n = int(samples)
    if n < 1:
        raise ValueError(f"samples must be >= 1, got {samples!r}")
    return nonneg_finite("t_first", t_first) + nonneg_finite("interval_s", interval_s) * (n - 1) * (2 * n - 1) / (6 * n)


def suppression_spin_rates_i(u_i: Vector3, C_bi_history: np.ndarray, guard_deg: float,
                             rate_rad_s: float) -> np.ndarray:
    """The gimbal-lock suppression's precession rate (m, 3) [rad/s] in i of the nominal axis
    ``u_i`` at each attitude of ``C_bi_history`` (m, 3, 3) (i to b): where the axis is within
    ``guard_deg`` of the outer gimbal axis ±z_b, ``rate_rad_s`` about (±z × u)/|±z × u| (which
    turns u away from ±z); 0 elsewhere, and everywhere for a 0 guard."""
    u = np.array(unit_vector(u_i, "u_i"))
    C = np.asarray(C_bi_history, dtype=float)
    z = C[:, 2, :]                      # z_b in i, per sample
    c = z @ u
    active = np.abs(c) >= math.cos(math.radians(guard_deg)) if guard_deg > 0.0 else np.zeros(len(c), bool)
    n = np.cross(np.sign(c)[:, None] * z, u)
    nn = np.linalg.norm(n, axis=1)
    ok = active & (nn > 1e-12)
    out = np.zeros_like(n)
    out[ok] = n[ok] / nn[ok, None]
    return nonneg_finite("rate_rad_s", rate_rad_s) * out


def suppression_spin_error_i(u_i: Vector3, C_bi_history: np.ndarray, dt: float, guard_deg: float,
                             rate_rad_s: float) -> np.ndarray:
    """The suppression's spin-axis error ε (3,) [rad] in i accumulated over the attitudes
    ``C_bi_history`` (m, 3, 3), ``dt`` [s] apart (first order: along the nominal axis):
    ε = Σ :func:`suppression_spin_rates_i` dt."""
    return nonneg_finite("dt", dt) * np.sum(suppression_spin_rates_i(u_i, C_bi_history, guard_deg, rate_rad_s),
                                            axis=0)
