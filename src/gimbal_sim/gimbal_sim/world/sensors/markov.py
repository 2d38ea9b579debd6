"""Gauss-Markov processes with exact discretisation (statistics independent of the step).

First order, per axis (correlation time τ, stationary standard deviation σ)::

    ḃ = -b/τ + w,   E[w(t)w(s)] = (2σ²/τ) δ(t-s)
    b[k+1] = φ b[k] + σ √(1-φ²) z[k],   φ = exp(-Δt/τ),  z ~ N(0, 1)

Second order, per axis (decay rate β, damped frequency λ, stationary σ)::

    θ̈ + 2β θ̇ + ω0² θ = w,   ω0² = β² + λ²,   E[w(t)w(s)] = 4 β ω0² σ² δ(t-s)

whose stationary covariance is diag(σ², ω0² σ²) for (θ, θ̇) and whose autocorrelation is
``R(τ) = σ² e^{-β|τ|} (cos λτ + (β/λ) sin λ|τ|)`` (λ → 0: ``σ² e^{-β|τ|} (1 + β|τ|)``, the
critically damped "second-order Gauss-Markov" of Gelb). The driving PSD 4βω0²σ² follows
from ∫|H(jω)|² dω/2π = 1/(4βω0²) for ``H(s) = 1/(s² + 2βs + ω0²)``. The discrete model is
``x[k+1] = Φ x[k] + L z[k]`` with ``Φ = exp(AΔt)`` and ``L Lᵀ = Q_d``, the exact discrete
covariance, computed once per Δt by Van Loan's method (no cancellation at small Δt).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.linalg import expm

from ._normals import NormalStream
from gimbal_kinematics.maths.validate import nonneg, per_axis, positive


def gm1_coefficients(sigma: float, tau_s: float, dt: float) -> tuple[float, float]:
    """``(φ, drive_sd)`` of the exact first-order Gauss-Markov step.

    ``sigma`` stationary standard deviation [any unit], ``tau_s`` correlation time [s]
    (``inf`` = random constant: φ = 1, no driving noise), ``dt`` step [s].
    ``drive_sd = σ √(1-φ²)`` with ``1-φ² = -expm1(-2Δt/τ)`` to keep precision at Δt ≪ τ.
    """
    if math.isinf(tau_s):
        return 1.0, 0.0
    phi = math.exp(-dt / tau_s)
    return phi, sigma * math.sqrt(-math.expm1(-2.0 * dt / tau_s))


def _broadcast(n_axes: int | None, **fields: tuple[float, ...]) -> tuple[int, list[list[float]]]:
    """The scalar-or-(n,) ``fields`` as lists of n: n is ``n_axes`` or the longest field's
    length, and a one-element field serves every axis."""
    n = n_axes if n_axes is not None else max(len(v) for v in fields.values())
    if n < 1:
        raise ValueError(f"n_axes must be >= 1, got {n}")
    out = []
    for name, vals in fields.items():
        if len(vals) not in (1, n):
            raise ValueError(f"{name} must be a scalar or have {n} elements, got {len(vals)}")
        out.append([vals[0]] * n if len(vals) == 1 else list(vals))
    return n, out


class FirstOrderGaussMarkov:
    """n independent first-order Gauss-Markov processes, exact in any step.

    Args:
        sigma: stationary standard deviation per axis [unit of the process]; scalar or (n,).
        tau_s: correlation time [s], > 0 (``inf`` = random constant); scalar or (n,).
        rng: the run's numpy Generator.
        dt: default step [s], > 0.
        n_axes: number of axes when ``sigma`` and ``tau_s`` are scalars.
        stationary_start: draw the initial state from N(0, σ²) (default), else start at 0.
    """

    def __init__(
        self,
        sigma: float | Sequence[float],
        tau_s: float | Sequence[float],
        rng: np.random.Generator,
        dt: float,
        n_axes: int | None = None,
        stationary_start: bool = True,
    ) -> None:
        tau = tuple(float(t) for t in ([tau_s] if isinstance(tau_s, (int, float)) else tau_s))
        n, (self._sigma, self._tau) = _broadcast(n_axes, sigma=per_axis("sigma", sigma), tau_s=tau)
        for s in self._sigma:
            nonneg("sigma", s)
        for t in self._tau:
            positive("tau_s", t, allow_inf=True)
        positive("dt", dt)
        self.n_axes = n
        self._normals = NormalStream(rng)
        if stationary_start:
            buf, j = self._normals.take(n)
            self._x = [self._sigma[i] * buf[j + i] for i in range(n)]
        else:
            self._x = [0.0] * n
        self._dt = -1.0
        self._set_dt(dt)

    def _set_dt(self, dt: float) -> None:
        positive("dt", dt)
        coef = [gm1_coefficients(s, t, dt) for s, t in zip(self._sigma, self._tau)]
        self._phi = [c[0] for c in coef]
        self._drive = [c[1] for c in coef]
        self._dt = dt

    def step(self, dt: float | None = None) -> list[float]:
        """Advance by ``dt`` [s] (default: the constructor's); returns the new state (n,)."""
        if dt is not None and dt != self._dt:
            self._set_dt(dt)
        n = self.n_axes
        buf, j = self._normals.take(n)
        x, phi, drive = self._x, self._phi, self._drive
        for i in range(n):
            x[i] = phi[i] * x[i] + drive[i] * buf[j + i]
        return list(x)

    @property
    def value(self) -> np.ndarray:
        """Current state, shape (n,)."""
        return np.array(self._x)


def gm2_discrete(beta: float, freq: float, sigma: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Φ, Q_d)`` of the exact second-order Gauss-Markov step for state (θ, θ̇).

    ``beta`` decay rate [1/s] > 0, ``freq`` damped angular frequency λ [rad/s] >= 0,
    ``sigma`` stationary RMS of θ, ``dt`` [s]. Shapes (2, 2) and (2, 2).
    """
    w0sq = beta * beta + freq * freq
    A = np.array([[0.0, 1.0], [-w0sq, -2.0 * beta]])
    q = 4.0 * beta * w0sq * sigma * sigma
    # Van Loan: expm([[-A, G q Gᵀ], [0, Aᵀ]] Δt) = [[·, Φ⁻¹ Q_d], [0, Φᵀ]].
    M = np.zeros((4, 4))
    M[:2, :2] = -A
    M[1, 3] = q
    M[2:, 2:] = A.T
    E = expm(M * dt)
    Phi = E[2:, 2:].T
    Qd = Phi @ E[:2, 2:]
    return Phi, 0.5 * (Qd + Qd.T)


def gm2_coefficients(beta: float, freq: float, sigma: float, dt: float) -> tuple[float, ...]:
    """``(Φ00, Φ01, Φ10, Φ11, L11, L21, L22)`` of :func:`gm2_discrete`'s step, ``L`` the lower
    Cholesky factor of ``Q_d`` (by hand; round-off negatives clipped so σ = 0 stays exactly 0)."""
    Phi, Qd = gm2_discrete(beta, freq, sigma, dt)
    l11 = math.sqrt(max(Qd[0, 0], 0.0))
    l21 = Qd[1, 0] / l11 if l11 > 0.0 else 0.0
    l22 = math.sqrt(max(Qd[1, 1] - l21 * l21, 0.0))
    return float(Phi[0, 0]), float(Phi[0, 1]), float(Phi[1, 0]), float(Phi[1, 1]), l11, float(l21), l22


class SecondOrderGaussMarkov:
    """n independent second-order Gauss-Markov processes (θ and θ̇ per axis), exact in any step.

    Args:
        sigma: stationary RMS of θ per axis; scalar or (n,).
        beta_per_s: decay rate β [1/s] > 0; scalar or (n,).
        freq_rad_s: damped angular frequency λ [rad/s] >= 0 (0 = critically damped); scalar or (n,).
        rng: the run's numpy Generator.
        dt: default step [s].
        n_axes: number of axes when all the above are scalars.
        stationary_start: draw (θ, θ̇) from the stationary N(0, diag(σ², ω0²σ²)) (default).
    """

    def __init__(
        self,
        sigma: float | Sequence[float],
        beta_per_s: float | Sequence[float],
        freq_rad_s: float | Sequence[float],
        rng: np.random.Generator,
        dt: float,
        n_axes: int | None = None,
        stationary_start: bool = True,
    ) -> None:
        n, (self._sigma, self._beta, self._freq) = _broadcast(
            n_axes, sigma=per_axis("sigma", sigma), beta_per_s=per_axis("beta_per_s", beta_per_s),
            freq_rad_s=per_axis("freq_rad_s", freq_rad_s))
        for s in self._sigma:
            nonneg("sigma", s)
        for b in self._beta:
            positive("beta_per_s", b)
        for f in self._freq:
            nonneg("freq_rad_s", f)
        positive("dt", dt)
        self.n_axes = n
        self._normals = NormalStream(rng)
        self._x = [0.0] * n
        self._v = [0.0] * n
        if stationary_start:
            buf, j = self._normals.take(2 * n)
            for i in range(n):
                w0 = math.sqrt(self._beta[i] ** 2 + self._freq[i] ** 2)
                self._x[i] = self._sigma[i] * buf[j + 2 * i]
                self._v[i] = w0 * self._sigma[i] * buf[j + 2 * i + 1]
        self._dt = -1.0
        self._set_dt(dt)

    def _set_dt(self, dt: float) -> None:
        positive("dt", dt)
        self._coef = [gm2_coefficients(b, f, s, dt) for s, b, f in zip(self._sigma, self._beta, self._freq)]
        self._dt = dt

    def step(self, dt: float | None = None) -> None:
        """Advance by ``dt`` [s] (default: the constructor's)."""
        if dt is not None and dt != self._dt:
            self._set_dt(dt)
        n = self.n_axes
        buf, j = self._normals.take(2 * n)
        x, v, coef = self._x, self._v, self._coef
        for i in range(n):
            p00, p01, p10, p11, l11, l21, l22 = coef[i]
            z1 = buf[j + 2 * i]
            z2 = buf[j + 2 * i + 1]
            xi, vi = x[i], v[i]
            x[i] = p00 * xi + p01 * vi + l11 * z1
            v[i] = p10 * xi + p11 * vi + l21 * z1 + l22 * z2

    @property
    def value(self) -> list[float]:
        """Current θ per axis (n,), a copy."""
        return list(self._x)

    @property
    def rate(self) -> list[float]:
        """Current θ̇ per axis (n,), a copy."""
        return list(self._v)

