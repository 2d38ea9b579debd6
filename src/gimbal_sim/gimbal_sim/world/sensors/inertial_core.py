"""Shared error core of the inertial sensors (gyros and accelerometers), SI units only.

Per axis i, over the step [t_k, t_k+Δt] the sensor reports the step-average

    y_i = Σ_j K_ij u_j + b_fix,i + b_gm,i(t_k+Δt) + b_rrw,i(t_k+Δt) + (N/√Δt) z_i

then clamps it to ±saturation and, when a quantum is set, quantises the increment y_i Δt
with the residual carried to the next step (so the sum of outputs never drifts from the
sum of inputs by more than half a quantum). ``u`` is the true quantity (inertial rate
[rad/s] or specific force [m/s²]) averaged over the step, ``K = I + diag(s) + M`` holds
the scale-factor errors ``s`` and the small-angle misalignment ``M`` (zero diagonal:
``M_ij`` is how much of true axis j leaks into sensed axis i), ``N`` is the white-noise
density (ARW in rad/√s for a gyro), so the *increment* noise has variance N²Δt and the
step-average *rate* noise N²/Δt, independent of how Δt is chosen.

The bias states are advanced to the end of the step first and held over it; holding
instead of integrating the Gauss-Markov term within the step changes the increment by
O(Δt/τ) of its bias-instability part, negligible for Δt ≪ τ.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._normals import NormalStream
from gimbal_kinematics.validate import broadcast, nonneg_finite, positive
from .markov import gm1_coefficients


@dataclass(frozen=True)
class ErrorSpecSI:
    """Error terms in SI (``u`` = unit of the sensed quantity: rad/s or m/s²).

    Built by the unit-suffixed parameter classes (``GyroParams.to_si()`` ...), which have
    validated every field; 1-tuples apply to every axis.
    """

    bias: tuple[float, ...] = (0.0,)  # given fixed bias [u]
    bias_sigma: float = 0.0  # run-to-run bias σ, drawn once per run [u]
    gm_sigma: float = 0.0  # bias-instability stationary σ [u]
    gm_tau: float = math.inf  # its correlation time [s]
    white_density: float = 0.0  # white noise density [u·√s]
    rrw_density: float = 0.0  # random-walk-of-bias density [u/√s]
    scale_factor: tuple[float, ...] = (0.0,)  # dimensionless
    misalignment: tuple[tuple[float, ...], ...] | None = None  # (n, n) rad, zero diagonal
    quantum: float = 0.0  # increment quantum [u·s], 0 = none
    saturation: float = math.inf  # output clamp [u]

    def __post_init__(self) -> None:
        for name in ("bias_sigma", "gm_sigma", "white_density", "rrw_density", "quantum"):
            nonneg_finite(name, getattr(self, name))
        positive("gm_tau", self.gm_tau, allow_inf=True)
        positive("saturation", self.saturation, allow_inf=True)


class InertialErrorCore:
    """n-axis inertial sensor error model (see module docstring).

    Args:
        spec: SI error terms.
        n_axes: number of sensing axes (e.g. 2 for the gimbal gyro, 3 for a triad).
        rng: the run's numpy Generator (fixed-bias draw, Gauss-Markov, noise).
        dt: default step [s]; a different ``dt`` passed to a step recomputes the exact
            discretisation.
    """

    def __init__(self, spec: ErrorSpecSI, n_axes: int, rng: np.random.Generator, dt: float) -> None:
        if not isinstance(n_axes, int) or isinstance(n_axes, bool) or n_axes < 1:
            raise ValueError(f"n_axes must be an int >= 1, got {n_axes!r}")
        n = n_axes
        self.n_axes = n
        self.spec = spec
        self._normals = NormalStream(rng)

        self._fixed = broadcast("bias", spec.bias, n)
        if spec.bias_sigma > 0.0:
            buf, j = self._normals.take(n)
            self._fixed = [self._fixed[i] + spec.bias_sigma * buf[j + i] for i in range(n)]

        self._has_gm = spec.gm_sigma > 0.0
        self._gm = [0.0] * n
        if self._has_gm:
            # Power-on bias instability is already in steady state.
            buf, j = self._normals.take(n)
            self._gm = [spec.gm_sigma * buf[j + i] for i in range(n)]
        self._has_rrw = spec.rrw_density > 0.0
        self._rrw = [0.0] * n
        self._has_white = spec.white_density > 0.0
        self._need = n * (int(self._has_gm) + int(self._has_rrw) + int(self._has_white))

        sf = broadcast("scale_factor", spec.scale_factor, n)
        self._kdiag = [1.0 + s for s in sf]
        self._K: list[list[float]] | None = None
        if spec.misalignment is not None:
            M = np.asarray(spec.misalignment, dtype=float)
            if M.shape != (n, n):
                raise ValueError(f"misalignment must have shape ({n}, {n}), got {M.shape}")
            self._K = [[(self._kdiag[i] if i == k else float(M[i, k])) for k in range(n)] for i in range(n)]

        self._quantum = spec.quantum
        self._residual = [0.0] * n
        self._sat = spec.saturation
        self._dt = -1.0
        self._set_dt(dt)

    def _set_dt(self, dt: float) -> None:
        positive("dt", dt)
        spec = self.spec
        self._phi, self._gm_drive = gm1_coefficients(spec.gm_sigma, spec.gm_tau, dt)
        self._rrw_drive = spec.rrw_density * math.sqrt(dt)
        self._white_sd = spec.white_density / math.sqrt(dt)
        self._dt = dt

    def _measure(self, u: Sequence[float], dt: float | None) -> tuple[list[float], float]:
        """Saturated step-average measurement (n,) and the step used."""
        if dt is not None and dt != self._dt:
            self._set_dt(dt)
        n = self.n_axes
        if len(u) != n:
            raise ValueError(f"input must have {n} elements, got {len(u)}")
        buf, j = self._normals.take(self._need)
        fixed, gm, rrw = self._fixed, self._gm, self._rrw
        if self._has_gm:
            phi, d = self._phi, self._gm_drive
            for i in range(n):
                gm[i] = phi * gm[i] + d * buf[j + i]
            j += n
        if self._has_rrw:
            d = self._rrw_drive
            for i in range(n):
                rrw[i] += d * buf[j + i]
            j += n
        K = self._K
        if K is None:
            kd = self._kdiag
            y = [kd[i] * u[i] + fixed[i] + gm[i] + rrw[i] for i in range(n)]
        else:
            y = [sum(K[i][k] * u[k] for k in range(n)) + fixed[i] + gm[i] + rrw[i] for i in range(n)]
        if self._has_white:
            sd = self._white_sd
            for i in range(n):
                y[i] += sd * buf[j + i]
        sat = self._sat
        if sat != math.inf:
            for i in range(n):
                if y[i] > sat:
                    y[i] = sat
                elif y[i] < -sat:
                    y[i] = -sat
        return y, self._dt

    def _quantise(self, inc: list[float]) -> list[float]:
        q = self._quantum
        res = self._residual
        for i in range(len(inc)):
            v = inc[i] + res[i]
            out = q * math.floor(v / q + 0.5)
            res[i] = v - out
            inc[i] = out
        return inc

    def step_increment(self, u_avg: Sequence[float], dt: float | None = None) -> list[float]:
        """Measured increment over the step (n,): rad for a gyro, m/s for an accelerometer.

        ``u_avg`` is the true quantity averaged over the step, i.e. true increment / Δt.
        """
        y, dt_used = self._measure(u_avg, dt)
        inc = [v * dt_used for v in y]
        if self._quantum > 0.0:
            inc = self._quantise(inc)
        return inc

    def step_rate(self, u_avg: Sequence[float], dt: float | None = None) -> list[float]:
        """Measured step-average (n,): rad/s for a gyro, m/s² for an accelerometer.

        With a quantum set, this is the quantised increment divided by Δt, like a digital
        sensor that reports pulse counts per sample period.
        """
        y, dt_used = self._measure(u_avg, dt)
        if self._quantum > 0.0:
            y = [v / dt_used for v in self._quantise([v * dt_used for v in y])]
        return y

    @property
    def true_bias(self) -> np.ndarray:
        """Total bias (fixed + Gauss-Markov + random walk) applied to the latest output; (n,)."""
        return np.array(self.true_bias_values())

    def true_bias_values(self) -> tuple[float, ...]:
        """:attr:`true_bias` as a tuple of floats (the per-step form, no array)."""
        return tuple([a + b + c for a, b, c in zip(self._fixed, self._gm, self._rrw)])

    @property
    def fixed_bias(self) -> np.ndarray:
        """Run-constant bias (given + drawn), shape (n,)."""
        return np.array(self._fixed)

    @property
    def gm_bias(self) -> np.ndarray:
        """Current Gauss-Markov bias-instability state, shape (n,)."""
        return np.array(self._gm)

    @property
    def rrw_bias(self) -> np.ndarray:
        """Current rate-random-walk bias state, shape (n,)."""
        return np.array(self._rrw)
