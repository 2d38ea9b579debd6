"""Shared error core of the inertial sensors (gyros and accelerometers), SI units only.

Per axis i, over the step [t_k, t_k+Δt] the sensor reports the step-average

    y_i = Σ_j K_ij u_j + a_i |u_i| + b_fix,i + b_gm,i(t_k+Δt) + b_rrw,i(t_k+Δt) + (N/√Δt) z_i

then clamps it to ±saturation and, when a quantum is set, quantises the increment y_i Δt
with the residual carried to the next step (so the sum of outputs never drifts from the
sum of inputs by more than half a quantum). ``u`` is the true quantity (inertial rate
[rad/s] or specific force [m/s²]) averaged over the step, ``K = I + diag(s) + M`` holds
the scale-factor errors ``s`` and the small-angle misalignment ``M`` (zero diagonal:
``M_ij`` is how much of true axis j leaks into sensed axis i: the axis non-orthogonality and
its misalignment to the case in one matrix), ``a_i = A_i/2`` is half the scale-factor
asymmetry ``A_i`` (IEEE Std 528: the scale factor measured with a positive input less the one
measured with a negative input, relative to the nominal one), so axis i's scale factor is
1 + s_i + A_i/2 for a positive input and 1 + s_i − A_i/2 for a negative one. ``N`` is the
white-noise density (ARW in rad/√s for a gyro), so the *increment* noise has variance N²Δt
and the step-average *rate* noise N²/Δt, independent of how Δt is chosen.

The scale-factor error, its asymmetry and the misalignment are each a given value plus, when
its 1σ is set, a per-run draw (per axis; per off-diagonal element for M), as the run-to-run
bias is: drawn once at construction, constant over the run. The three draws come from
children of the sensor's stream (``Generator.spawn``: scale factor, asymmetry, misalignment),
never from the stream itself, so setting them changes no other draw of the sensor: the same
seed gives the same biases and noise with or without them. Unset (all zero), nothing is drawn
and the kernel skips the asymmetry and the off-diagonal terms, so the outputs are the bits of
a sensor without them.

The bias states are advanced to the end of the step first and held over it; holding
instead of integrating the Gauss-Markov term within the step changes the increment by
O(Δt/τ) of its bias-instability part, negligible for Δt ≪ τ.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import sensor_kernels as sk
from ._normals import NormalStream
from gimbal_kinematics.maths.units import PPM, URAD
from gimbal_kinematics.maths.validate import broadcast, nonneg_finite, per_axis, positive
from .markov import gm1_coefficients


def misalignment_matrix(name: str, value: object) -> tuple[tuple[float, ...], ...] | None:
    """A given misalignment M checked (square, finite, zero diagonal) as a tuple of rows, or
    None; ``ValueError`` naming ``name``."""
    if value is None:
        return None
    try:
        M = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a square matrix of numbers, got {value!r}") from exc
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] < 1:
        raise ValueError(f"{name} must be a square (n, n) matrix, got shape {M.shape}")
    if not np.all(np.isfinite(M)):
        raise ValueError(f"{name} must be finite")
    if np.any(np.diag(M) != 0.0):
        raise ValueError(f"{name} must have a zero diagonal (scale errors go in scale_factor_ppm)")
    return tuple(tuple(float(x) for x in row) for row in M)


def off_diagonal(name: str, values: Sequence[float], n: int, scale: float = 1.0
                 ) -> tuple[tuple[float, ...], ...] | None:
    """The (n, n) misalignment whose off-diagonal elements are ``values`` × ``scale``, row by
    row (n = 3: M_xy, M_xz, M_yx, M_yz, M_zx, M_zy; n = 2: M_12, M_21), or None when ``values``
    is empty or all zero (no misalignment); ``ValueError`` naming ``name``."""
    vals = [float(v) for v in values]
    if not vals or all(v == 0.0 for v in vals):
        if vals and len(vals) != n * (n - 1):
            raise ValueError(f"{name} needs {n * (n - 1)} values (the off-diagonal elements row by row), "
                             f"or none, got {len(vals)}")
        return None
    if len(vals) != n * (n - 1) or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{name} needs {n * (n - 1)} finite values (the off-diagonal elements row by row), "
                         f"or none, got {vals}")
    M = np.zeros((n, n))
    M[~np.eye(n, dtype=bool)] = np.asarray(vals) * scale
    return misalignment_matrix(name, M)


def check_bias_terms(params: Any, unit: str) -> None:
    """Check the bias fields every inertial sensor's parameters share, named by their unit
    suffix ``unit`` (``bias_<unit>``, ``bias_sigma_<unit>``, ``bias_instability_<unit>``,
    ``bias_instability_tau_s``), and store the per-axis bias on the frozen ``params``;
    ``ValueError`` naming the field."""
    name = f"bias_{unit}"
    object.__setattr__(params, name, per_axis(name, getattr(params, name)))
    for name in (f"bias_sigma_{unit}", f"bias_instability_{unit}"):
        nonneg_finite(name, getattr(params, name))
    positive("bias_instability_tau_s", params.bias_instability_tau_s, allow_inf=True)


def bias_terms_si(params: Any, unit: str, scale: float) -> dict[str, Any]:
    """Those fields (checked by :func:`check_bias_terms`) as :class:`ErrorSpecSI` keywords,
    ``scale`` being the SI value of one ``unit``."""
    return dict(
        bias=tuple(b * scale for b in getattr(params, f"bias_{unit}")),
        bias_sigma=getattr(params, f"bias_sigma_{unit}") * scale,
        gm_sigma=getattr(params, f"bias_instability_{unit}") * scale,
        gm_tau=float(params.bias_instability_tau_s),
    )


def check_axis_errors(params: Any) -> None:
    """Check the scale-factor, asymmetry and misalignment fields every inertial sensor's
    parameters share (``scale_factor_ppm``, ``scale_factor_sigma_ppm``, ``scale_asymmetry_ppm``,
    ``scale_asymmetry_sigma_ppm``, ``misalignment_rad``, ``misalignment_sigma_urad``) and store
    the normalised values on the frozen ``params``; ``ValueError`` naming the field."""
    set_ = object.__setattr__
    set_(params, "scale_factor_ppm", per_axis("scale_factor_ppm", params.scale_factor_ppm))
    set_(params, "misalignment_rad", misalignment_matrix("misalignment_rad", params.misalignment_rad))
    nonneg_finite("scale_factor_sigma_ppm", params.scale_factor_sigma_ppm)
    set_(params, "scale_asymmetry_ppm", per_axis("scale_asymmetry_ppm", params.scale_asymmetry_ppm))
    nonneg_finite("scale_asymmetry_sigma_ppm", params.scale_asymmetry_sigma_ppm)
    nonneg_finite("misalignment_sigma_urad", params.misalignment_sigma_urad)


def axis_errors_si(params: Any) -> dict[str, Any]:
    """Those fields (checked by :func:`check_axis_errors`) as :class:`ErrorSpecSI` keywords:
    dimensionless scale factors and asymmetries, the misalignment in rad."""
    return dict(
        scale_factor=tuple(s * PPM for s in params.scale_factor_ppm),
        misalignment=params.misalignment_rad,
        scale_factor_sigma=params.scale_factor_sigma_ppm * PPM,
        asymmetry=tuple(a * PPM for a in params.scale_asymmetry_ppm),
        asymmetry_sigma=params.scale_asymmetry_sigma_ppm * PPM,
        misalignment_sigma=params.misalignment_sigma_urad * URAD,
    )


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
    scale_factor_sigma: float = 0.0  # run-to-run scale-factor error σ per axis, dimensionless
    asymmetry: tuple[float, ...] = (0.0,)  # scale-factor asymmetry A = K+ − K−, dimensionless
    asymmetry_sigma: float = 0.0  # run-to-run asymmetry σ per axis, dimensionless
    misalignment_sigma: float = 0.0  # run-to-run σ of each off-diagonal M_ij [rad]
    quantum: float = 0.0  # increment quantum [u·s], 0 = none
    saturation: float = math.inf  # output clamp [u]

    def __post_init__(self) -> None:
        for name in ("bias_sigma", "gm_sigma", "white_density", "rrw_density", "quantum", "scale_factor_sigma",
                     "asymmetry_sigma", "misalignment_sigma"):
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

        # the kernel's arrays: rows (1 + s, b_fix, b_gm, b_rrw, quantiser residual, A/2), K, constants
        self.rows = np.zeros((sk.N_ROWS, n))
        rows = self.rows
        rows[sk.R_FIXED] = broadcast("bias", spec.bias, n)
        if spec.bias_sigma > 0.0:
            buf, j = self._normals.take(n)
            rows[sk.R_FIXED] = rows[sk.R_FIXED] + spec.bias_sigma * np.asarray(buf[j:j + n], dtype=float)
        self._has_gm = spec.gm_sigma > 0.0
        if self._has_gm:
            # Power-on bias instability is already in steady state.
            buf, j = self._normals.take(n)
            rows[sk.R_GM] = spec.gm_sigma * np.asarray(buf[j:j + n], dtype=float)
        self._has_rrw = spec.rrw_density > 0.0
        self._has_white = spec.white_density > 0.0
        self._need = n * (int(self._has_gm) + int(self._has_rrw) + int(self._has_white))
        scale, asym, M = self._scale_errors(spec, n, rng)
        rows[sk.R_KDIAG] = [1.0 + s for s in scale]
        rows[sk.R_ASYM] = [0.5 * a for a in asym]
        self.K = np.zeros((n, n))
        if M is not None:
            self.K[:] = M
            self.K[np.diag_indices(n)] = rows[sk.R_KDIAG]
        self.constants = np.zeros(sk.N_INERTIAL)
        c = self.constants
        c[sk.I_SATURATION], c[sk.I_QUANTUM] = spec.saturation, spec.quantum
        c[sk.I_HAS_GM], c[sk.I_HAS_RRW] = float(self._has_gm), float(self._has_rrw)
        c[sk.I_HAS_K] = float(M is not None)
        c[sk.I_HAS_ASYM] = float(any(a != 0.0 for a in asym))
        self._out = np.zeros(n)
        self._dt = -1.0
        self._set_dt(dt)

    @staticmethod
    def _scale_errors(spec: ErrorSpecSI, n: int, rng: np.random.Generator
                      ) -> tuple[list[float], list[float], np.ndarray | None]:
        """The run's scale-factor errors s (n), asymmetries A (n) and misalignment M ((n, n) or
        None): the given values plus the per-run draws, from the stream's children (module
        docstring); nothing is drawn when no σ is set."""
        scale = broadcast("scale_factor", spec.scale_factor, n)
        asym = broadcast("asymmetry", spec.asymmetry, n)
        M = None
        if spec.misalignment is not None:
            M = np.asarray(spec.misalignment, dtype=float)
            if M.shape != (n, n):
                raise ValueError(f"misalignment must have shape ({n}, {n}), got {M.shape}")
        if spec.scale_factor_sigma > 0.0 or spec.asymmetry_sigma > 0.0 or spec.misalignment_sigma > 0.0:
            r_scale, r_asym, r_mis = rng.spawn(3)
            if spec.scale_factor_sigma > 0.0:
                scale = [s + spec.scale_factor_sigma * float(z) for s, z in zip(scale, r_scale.standard_normal(n))]
            if spec.asymmetry_sigma > 0.0:
                asym = [a + spec.asymmetry_sigma * float(z) for a, z in zip(asym, r_asym.standard_normal(n))]
            if spec.misalignment_sigma > 0.0 and n > 1:
                off = ~np.eye(n, dtype=bool)  # the off-diagonal elements, row by row
                M = np.zeros((n, n)) if M is None else M.copy()
                M[off] += spec.misalignment_sigma * r_mis.standard_normal(n * (n - 1))
        return scale, asym, M

    @property
    def scale_factor_error(self) -> np.ndarray:
        """The run's scale-factor errors s (given + drawn), shape (n,)."""
        return self.rows[sk.R_KDIAG] - 1.0

    @property
    def scale_asymmetry(self) -> np.ndarray:
        """The run's scale-factor asymmetries A = K+ − K− (given + drawn), shape (n,)."""
        return 2.0 * self.rows[sk.R_ASYM]

    @property
    def misalignment(self) -> np.ndarray:
        """The run's misalignment M (given + drawn; zero diagonal), shape (n, n)."""
        M = self.K.copy() if self.constants[sk.I_HAS_K] != 0.0 else np.zeros((self.n_axes, self.n_axes))
        M[np.diag_indices(self.n_axes)] = 0.0
        return M

    def _set_dt(self, dt: float) -> None:
        positive("dt", dt)
        spec, c = self.spec, self.constants
        c[sk.I_PHI], c[sk.I_GM_DRIVE] = gm1_coefficients(spec.gm_sigma, spec.gm_tau, dt)
        c[sk.I_RRW_DRIVE] = spec.rrw_density * math.sqrt(dt)
        c[sk.I_WHITE_SD] = spec.white_density / math.sqrt(dt)
        c[sk.I_DT] = dt
        self._dt = dt

    def _step(self, u: Sequence[float], dt: float | None, increment: bool) -> list[float]:
        """One step through :func:`.sensor_kernels.inertial_step` (module docstring)."""
        if dt is not None and dt != self._dt:
            self._set_dt(dt)
        n = self.n_axes
        if len(u) != n:
            raise ValueError(f"input must have {n} elements, got {len(u)}")
        buf, j = self._normals.take(self._need)
        z = np.asarray(buf[j:j + self._need], dtype=float)
        sk.inertial_step(np.asarray(u, dtype=float), self.rows, self.K, self.constants, z, increment, self._out)
        return self._out.tolist()

    def step_increment(self, u_avg: Sequence[float], dt: float | None = None) -> list[float]:
        """Measured increment over the step (n,): rad for a gyro, m/s for an accelerometer.

        ``u_avg`` is the true quantity averaged over the step, i.e. true increment / Δt.
        """
        return self._step(u_avg, dt, True)

    def step_rate(self, u_avg: Sequence[float], dt: float | None = None) -> list[float]:
        """Measured step-average (n,): rad/s for a gyro, m/s² for an accelerometer.

        With a quantum set, this is the quantised increment divided by Δt, like a digital
        sensor that reports pulse counts per sample period.
        """
        return self._step(u_avg, dt, False)

    @property
    def true_bias(self) -> np.ndarray:
        """Total bias (fixed + Gauss-Markov + random walk) applied to the latest output; (n,)."""
        return np.array(self.true_bias_values())

    def true_bias_values(self) -> tuple[float, ...]:
        """:attr:`true_bias` as a tuple of floats (the per-step form, no array)."""
        rows = self.rows
        return tuple((rows[sk.R_FIXED] + rows[sk.R_GM] + rows[sk.R_RRW]).tolist())

    @property
    def fixed_bias(self) -> np.ndarray:
        """Run-constant bias (given + drawn), shape (n,)."""
        return self.rows[sk.R_FIXED].copy()

    @property
    def gm_bias(self) -> np.ndarray:
        """Current Gauss-Markov bias-instability state, shape (n,)."""
        return self.rows[sk.R_GM].copy()

    @property
    def rrw_bias(self) -> np.ndarray:
        """Current rate-random-walk bias state, shape (n,)."""
        return self.rows[sk.R_RRW].copy()
