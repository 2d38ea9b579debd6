"""Ship angular-flexure Kalman filter from two ring-laser-gyro units (paper 5, docs/spec.md §3.5).

Frames and attitude integration
-------------------------------
LGU1 (body frame b1) sits by the master INS, LGU2 (b2) at the peripheral device. Each unit's
attitude is integrated from its own incremental angles relative to its own initial body frame,
i1 = b1(t0) and i2 = b2(t0), both non-rotating, with both initial DCMs equal to I:
``Ĉ_i·b· ← Ĉ_i·b· exp([Δα×])`` (exact for a rotation vector Δα over the sample).

Observation and state: :mod:`.flexure_model` (paper 5 eqs. 3-6 re-derived, the 18 states).

Robustness
----------
Each unit's sample is checked (:meth:`FlexureKf.check_sample`: non-finite or malformed
input is rejected and counted); the edge pairs the checked samples by stamp, in stamp order
(:class:`gimbal_kinematics.timing.sync.StampPairs`, which also refuses repeated and late
stamps), and the filter runs on each pair (:meth:`FlexureKf.on_pair`). A lost sample (a gap
between one pair's start and the previous pair's end, or a sample of one unit without its
partner, whose own sample is then dropped too) loses that interval's rotation for good in
both units. The common part cancels in Ĉ_i1b1ᵀĈ_i2b2 (A is the filter's own attitude), but
the flexure change over the interval would stay in θ_d as a step (tens of arcseconds for a
second of dynamic flexure). The filter therefore *re-anchors*: it propagates to the start of
the next complete pair, restarts both attitudes at I there and sets θ_d := Φ + θ (exact,
since the new initial frames differ by the flexure at that instant), transforming the
covariance linearly, so what was learnt is kept. A gap longer than ``max_gap_s`` resets the
filter, with the reason recorded; so does the node's input policy on a backward clock jump
(:meth:`FlexureKf.reset`: the filter sees each run's samples in stamp order).
Measurements beyond the chi-square gate are not fused and counted. Because a corrupted
increment (a spike) stays in the integrated attitude for good, it shows as a persistent jump
of Z rather than one outlier: after ``max_gate_rejections`` gated measurements in a row the
filter re-anchors (dropping the corrupted attitude history, keeping the clean state); if
the gate keeps rejecting after that, the model no longer explains the data and it resets.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, orthonormalize
from gimbal_kinematics.maths.units import ARCSEC, DEG, DEG_H, DEG_H_RT_H, DEG_RT_H
from gimbal_kinematics.maths.validate import nonneg_finite, of_type, per_axis, positive
from gimbal_kinematics.params.table import ParameterError

from gimbal_kinematics.maths import kalman
from .flexure_model import (
    EPS, N_STATES, PHI_K, PHI_K1, THETA_D, THETA_K, THETA_K1, ar2_coefficients, match_attitudes,
    observation_matrix, predicted_observation,
)

#: Quasi-static flexure models.
QS_MODELS = ("random_constant", "random_walk_rate")

#: Largest attitude-matching angle |Z| accepted [rad] (small_angles_from_dcm's default limit);
#: beyond it the first-order extraction misleads and the filter resets.
_MAX_MATCH_ANGLE = 0.1


@dataclass(frozen=True)
class FlexureKfParams:
    """Filter parameters (engineering units in the field names; per-axis fields take a scalar
    or a (roll, pitch, yaw) triple). Defaults match the paper 5 simulation (docs/spec.md §3.5).

    Attributes:
        quasi_static_model: ``"random_constant"`` or ``"random_walk_rate"`` (eq. 10).
        filter_period_s: nominal Kalman step T [s]; attitudes integrate every LGU sample,
            the filter steps once at least T has elapsed (LGU 10 Hz and T = 0.1 s: every pair).
        qs_initial_sigma_deg: prior σ of the quasi-static flexure at t0 [°].
        qs_rate_initial_sigma_deg_h: prior σ of its rate [°/h] (``random_walk_rate`` only).
        qs_rate_rw_arcsec_s_rt_s: rate random walk of Φ [″/s/√s] (``random_walk_rate``).
        qs_rw_arcsec_rt_s: random walk of Φ [″/√s] (``random_constant``; small = constant).
        dynamic_rms_arcsec, dynamic_beta_per_s, dynamic_freq_rad_s: second-order Markov
            RMS [″], decay rate β [1/s] and damped frequency λ [rad/s] (eq. 12).
        bias_diff_initial_sigma_deg_h: prior σ of ε1 − ε2 [°/h].
        bias_diff_rw_deg_h_rt_h: its random walk [°/h/√h].
        lgu_arw_deg_rt_h: angle random walk of each LGU [°/√h] (drives θ_d).
        meas_noise_arcsec: σ of the attitude-matching measurement [″] (residual model
            error; the LGU noise itself enters through θ_d).
        anchor_sigma_arcsec: σ given to θ_d − (Φ + θ) at (re-)anchoring [″].
        second_order_observation: predict Z with :func:`predicted_observation` (second
            order) instead of H X (the paper's first order); the gain uses H either way.
        gate_probability: chi-square gate (3 dof) probability; None disables gating.
        max_gate_rejections: consecutive gated measurements that trigger a re-anchor (and,
            when they go on after one, a reset).
        max_gap_s: a data gap longer than this resets instead of re-anchoring [s].
        dt_tolerance: relative tolerance on stamp spacing vs the samples' dt.
    """

    quasi_static_model: str = "random_walk_rate"
    filter_period_s: float = 0.1
    qs_initial_sigma_deg: float | tuple[float, ...] = 0.5
    qs_rate_initial_sigma_deg_h: float | tuple[float, ...] = 10.0
    qs_rate_rw_arcsec_s_rt_s: float | tuple[float, ...] = 1.0
    qs_rw_arcsec_rt_s: float | tuple[float, ...] = 0.001
    dynamic_rms_arcsec: float | tuple[float, ...] = (20.0, 60.0, 40.0)
    dynamic_beta_per_s: float | tuple[float, ...] = 0.2146
    dynamic_freq_rad_s: float | tuple[float, ...] = 0.0
    bias_diff_initial_sigma_deg_h: float | tuple[float, ...] = 0.1
    bias_diff_rw_deg_h_rt_h: float | tuple[float, ...] = 0.001
    lgu_arw_deg_rt_h: float = 0.001
    meas_noise_arcsec: float = 1.0
    anchor_sigma_arcsec: float = 0.1
    second_order_observation: bool = True
    gate_probability: float | None = 0.99999
    max_gate_rejections: int = 200
    max_gap_s: float = 5.0
    dt_tolerance: float = 0.25

    def __post_init__(self) -> None:
        if self.quasi_static_model not in QS_MODELS:
            raise ValueError(f"quasi_static_model must be one of {QS_MODELS}, got {self.quasi_static_model!r}")
        set_ = object.__setattr__
        for name in ("qs_initial_sigma_deg", "qs_rate_initial_sigma_deg_h", "qs_rate_rw_arcsec_s_rt_s",
                     "qs_rw_arcsec_rt_s", "dynamic_rms_arcsec", "dynamic_beta_per_s", "dynamic_freq_rad_s",
                     "bias_diff_initial_sigma_deg_h", "bias_diff_rw_deg_h_rt_h"):
            vals = per_axis(name, getattr(self, name), 3)
            for x in vals:
                nonneg_finite(name, x)
            set_(self, name, vals)
        for name in ("qs_initial_sigma_deg", "dynamic_rms_arcsec", "dynamic_beta_per_s",
                     "bias_diff_initial_sigma_deg_h"):
            for x in getattr(self, name):
                positive(name, x)
        # The active quasi-static model needs process noise or its covariance collapses.
        active = "qs_rate_rw_arcsec_s_rt_s" if self.quasi_static_model == "random_walk_rate" else "qs_rw_arcsec_rt_s"
        for x in getattr(self, active):
            positive(active, x)
        for name in ("filter_period_s", "meas_noise_arcsec", "anchor_sigma_arcsec", "max_gap_s",
                     "dt_tolerance"):
            positive(name, getattr(self, name))
        nonneg_finite("lgu_arw_deg_rt_h", self.lgu_arw_deg_rt_h)
        if self.dt_tolerance >= 0.5:
            raise ValueError(f"dt_tolerance must be < 0.5, got {self.dt_tolerance}")
        if self.gate_probability is not None:
            positive("gate_probability", self.gate_probability)
            if not self.gate_probability < 1.0:
                raise ValueError(f"gate_probability must be in (0, 1) or None, got {self.gate_probability}")
        val = self.max_gate_rejections
        if not isinstance(val, int) or isinstance(val, bool) or val < 1:
            raise ValueError(f"max_gate_rejections must be an integer >= 1, got {val!r}")
        if self.max_gap_s <= self.filter_period_s:
            raise ValueError(f"max_gap_s must exceed filter_period_s ({self.filter_period_s}), got {self.max_gap_s}")

    @classmethod
    def from_values(cls, v: dict) -> FlexureKfParams:
        """The parameters from a ``flexure_estimator`` node's values (name -> value, as
        declared in :mod:`.flexure_estimator_params`); :class:`ParameterError` names the
        parameter refused. A ``gate_probability`` of 0 disables the gate (None here)."""
        try:
            return cls(
                quasi_static_model=v["quasi_static_model"], filter_period_s=v["filter_period_s"],
                qs_initial_sigma_deg=v["qs_initial_sigma_deg"],
                qs_rate_initial_sigma_deg_h=v["qs_rate_initial_sigma_deg_h"],
                qs_rate_rw_arcsec_s_rt_s=v["qs_rate_rw_arcsec_s_rt_s"], qs_rw_arcsec_rt_s=v["qs_rw_arcsec_rt_s"],
                dynamic_rms_arcsec=tuple(v["dynamic_rms_arcsec"]), dynamic_beta_per_s=tuple(v["dynamic_beta_per_s"]),
                dynamic_freq_rad_s=tuple(v["dynamic_freq_rad_s"]),
                bias_diff_initial_sigma_deg_h=v["bias_diff_initial_sigma_deg_h"],
                bias_diff_rw_deg_h_rt_h=v["bias_diff_rw_deg_h_rt_h"], lgu_arw_deg_rt_h=v["lgu_arw_deg_rt_h"],
                meas_noise_arcsec=v["meas_noise_arcsec"], second_order_observation=v["second_order_observation"],
                gate_probability=v["gate_probability"] or None, max_gate_rejections=v["max_gate_rejections"],
                max_gap_s=v["max_gap_s"],
            )
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


class FlexureEstimate(NamedTuple):
    """One filter output at stamp ``t`` [s]. Angles [rad], rates [rad/s], each (3,)
    (roll, pitch, yaw), with 1σ companions. ``flexure`` = quasi-static + dynamic;
    ``relative_attitude`` θ_d; ``innovation`` (3,) [rad]; ``d2`` its squared Mahalanobis
    distance; ``accepted`` whether the gate let it in."""

    t: float
    flexure: np.ndarray
    flexure_sigma: np.ndarray
    quasi_static: np.ndarray
    quasi_static_sigma: np.ndarray
    dynamic: np.ndarray
    dynamic_sigma: np.ndarray
    bias_diff: np.ndarray
    bias_diff_sigma: np.ndarray
    relative_attitude: np.ndarray
    innovation: np.ndarray
    d2: float
    accepted: bool


#: Counter names on :attr:`FlexureKf.counters`.
COUNTERS = ("samples", "pairs", "updates", "gated", "nonfinite", "malformed", "bad_dt", "gaps", "reanchors",
            "resets")


class FlexureKf:
    """Message-driven 18-state flexure filter (module docstring). No clock of its own: time
    is the messages' stamps [s].

    Args:
        params: filter parameters.
    """

    def __init__(self, params: FlexureKfParams | None = None) -> None:
        params = FlexureKfParams() if params is None else params
        of_type("params", params, FlexureKfParams)
        self.params = params
        p = params
        self._q_rw = np.array([(x * ARCSEC) ** 2 for x in p.qs_rw_arcsec_rt_s])  # type: ignore[union-attr]
        self._q_rate = np.array([(x * ARCSEC) ** 2 for x in p.qs_rate_rw_arcsec_s_rt_s])  # type: ignore[union-attr]
        self._q_arw = 2.0 * (p.lgu_arw_deg_rt_h * DEG_RT_H) ** 2
        self._q_eps = np.array([(x * DEG_H_RT_H) ** 2 for x in p.bias_diff_rw_deg_h_rt_h])  # type: ignore[union-attr]
        self._dyn = list(zip(p.dynamic_beta_per_s, p.dynamic_freq_rad_s,  # type: ignore[arg-type]
                             [x * ARCSEC for x in p.dynamic_rms_arcsec]))  # type: ignore[union-attr]
        self._R = np.eye(3) * (p.meas_noise_arcsec * ARCSEC) ** 2
        self._gate = math.inf if p.gate_probability is None else kalman.chi2_gate(3, p.gate_probability)
        self._H = observation_matrix(np.eye(3))
        # θ_d := Φ_k + θ_k, identity elsewhere: the (re-)anchoring map.
        self._anchor_map = np.eye(N_STATES)
        self._anchor_map[THETA_D, THETA_D] = 0.0
        self._anchor_map[THETA_D, PHI_K] = np.eye(3)
        self._anchor_map[THETA_D, THETA_K] = np.eye(3)
        self._model_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.counters: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        #: Reasons of the resets so far (newest last, at most 20 kept).
        self.reset_reasons: list[str] = []
        #: Called on every reset: the edge forgets the samples waiting for their partner.
        self.on_reset: Callable[[], None] | None = None
        #: What the last sample or pair did: the counters it raised, in order.
        self.events: list[str] = []
        self._clear()

    # ------------------------------------------------------------------ public API
    def on_pair(self, t: float, lgu1: tuple[tuple, float], lgu2: tuple[tuple, float]) -> FlexureEstimate | None:
        """Both units' checked ``(dalpha, dt)`` of stamp ``t`` [s], later than
        :attr:`paired_until`. Returns the estimate when the pair ends a filter step."""
        self.events.clear()
        return self._on_pair(t, lgu1[0], lgu2[0], lgu1[1], lgu2[1])

    def _count(self, name: str) -> None:
        self.counters[name] += 1
        self.events.append(name)

    @property
    def paired_until(self) -> float:
        """The stamp [s] of the last pair taken, which the attitudes reach (NaN: none yet)."""
        return self._t_att

    def reset(self, reason: str) -> None:
        """Forget everything (state, attitudes, pending samples); record ``reason``."""
        self._count("resets")
        self.reset_reasons.append(reason)
        del self.reset_reasons[:-20]
        self._clear()
        if self.on_reset is not None:
            self.on_reset()

    @property
    def last_reset_reason(self) -> str | None:
        return self.reset_reasons[-1] if self.reset_reasons else None

    @property
    def initialized(self) -> bool:
        return self._x is not None

    @property
    def state(self) -> np.ndarray | None:
        """State X (18,) (copy), or None before the first pair."""
        return None if self._x is None else self._x.copy()

    @property
    def covariance(self) -> np.ndarray | None:
        """Covariance (18, 18) (copy), or None before the first pair."""
        return None if self._P is None else self._P.copy()

    @property
    def attitudes(self) -> tuple[np.ndarray, np.ndarray]:
        """Integrated ``(Ĉ_i1b1, Ĉ_i2b2)`` (copies), each (3, 3)."""
        return self._C1.copy(), self._C2.copy()

    def estimate(self) -> FlexureEstimate | None:
        """The current estimate (no innovation: zeros, d2 = nan), or None before the first pair."""
        if self._x is None:
            return None
        return self._output(self._t_kf, np.zeros(3), math.nan, False)

    # ------------------------------------------------------------------ model
    def discrete_model(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F, Q)`` (18, 18) of one step ``dt`` [s] with the θ_d–ε coupling left at zero
        (it depends on the attitude; the filter fills ``F[θ_d, ε] = C̄ dt``). Cached copies
        are reused internally; the returned arrays are copies."""
        F, Q = self._model(dt)
        F = F.copy()
        F[THETA_D, EPS] = 0.0
        return F, Q.copy()

    def _model(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        key = round(dt * 1e6)  # stamp differences carry float noise far below 1 µs
        cached = self._model_cache.get(key)
        if cached is not None:
            return cached
        F = np.zeros((N_STATES, N_STATES))
        Q = np.zeros((N_STATES, N_STATES))
        I3 = np.eye(3)
        if self.params.quasi_static_model == "random_walk_rate":
            F[PHI_K, PHI_K] = 2.0 * I3
            F[PHI_K, PHI_K1] = -I3
            Q[PHI_K, PHI_K] = np.diag(self._q_rate * dt ** 3)
        else:
            F[PHI_K, PHI_K] = I3
            Q[PHI_K, PHI_K] = np.diag(self._q_rw * dt)
        F[PHI_K1, PHI_K] = I3
        for i, (beta, freq, sigma) in enumerate(self._dyn):
            a1, a2, var_e = ar2_coefficients(beta, freq, sigma, dt)
            th, th1 = THETA_K.start + i, THETA_K1.start + i
            F[th, th] = a1
            F[th, th1] = a2
            Q[th, th] = var_e
        F[THETA_K1, THETA_K] = I3
        F[THETA_D, THETA_D] = I3
        Q[THETA_D, THETA_D] = self._q_arw * dt * I3
        F[EPS, EPS] = I3
        Q[EPS, EPS] = np.diag(self._q_eps * dt)
        if len(self._model_cache) > 16:
            self._model_cache.clear()
        self._model_cache[key] = (F, Q)
        return F, Q

    def _initial(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.params
        T = p.filter_period_s
        P = np.zeros((N_STATES, N_STATES))
        for i in range(3):
            f, f1, eps = PHI_K.start + i, PHI_K1.start + i, EPS.start + i
            th, th1 = THETA_K.start + i, THETA_K1.start + i
            s0 = (p.qs_initial_sigma_deg[i] * DEG) ** 2  # type: ignore[index]
            if p.quasi_static_model == "random_walk_rate":
                extra = (p.qs_rate_initial_sigma_deg_h[i] * DEG_H * T) ** 2  # type: ignore[index]
            else:
                extra = self._q_rw[i] * T
            P[f, f] = s0
            P[f, f1] = P[f1, f] = s0
            P[f1, f1] = s0 + extra
            beta, freq, sigma = self._dyn[i]
            a1, a2, _ = ar2_coefficients(beta, freq, sigma, T)
            rho1 = a1 / (1.0 - a2)
            P[th, th] = P[th1, th1] = sigma * sigma
            P[th, th1] = P[th1, th] = rho1 * sigma * sigma
            P[eps, eps] = (p.bias_diff_initial_sigma_deg_h[i] * DEG_H) ** 2  # type: ignore[index]
        x = np.zeros(N_STATES)
        x, P = self._anchor(x, P)
        return kalman.check_state(x, P, "FlexureKf")

    def _anchor(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """θ_d := Φ_k + θ_k (new initial frames at the current body frames)."""
        T = self._anchor_map
        P = T @ P @ T.T
        P[THETA_D, THETA_D] += np.eye(3) * (self.params.anchor_sigma_arcsec * ARCSEC) ** 2
        return T @ x, kalman.symmetrize(P)

    # ------------------------------------------------------------------ message handling
    def _clear(self) -> None:
        self._x: np.ndarray | None = None
        self._P: np.ndarray | None = None
        self._C1 = np.eye(3)
        self._C2 = np.eye(3)
        self._C1_kf = np.eye(3)
        self._t_kf = math.nan  # time of the filter state
        self._t_att = math.nan  # time of the integrated attitudes (end of the last pair)
        self._n_att = 0
        self._rejections = 0
        self._gate_reanchored = False

    def check_sample(self, t: float, dalpha: Sequence[float], dt: float) -> tuple[float, tuple, float] | None:
        """One unit's incremental angle ``dalpha`` [rad] (3,) over ``dt`` [s] ending at stamp
        ``t`` [s]: ``(t, dalpha, dt)`` as floats, or None (counted) when it cannot be used."""
        self.events.clear()
        self._count("samples")
        try:
            t = float(t)
            dt = float(dt)
            if len(dalpha) != 3:
                raise ValueError
            d = (float(dalpha[0]), float(dalpha[1]), float(dalpha[2]))
        except (TypeError, ValueError):
            self._count("malformed")
            return None
        if not (math.isfinite(t) and math.isfinite(dt) and math.isfinite(d[0] + d[1] + d[2])):
            self._count("nonfinite")
            return None
        if not 0.0 < dt <= self.params.max_gap_s or d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1.0:
            # A rotation over 1 rad in one sample is not a ship's.
            self._count("bad_dt" if not 0.0 < dt <= self.params.max_gap_s else "malformed")
            return None
        return t, d, dt

    def _on_pair(self, t: float, d1: tuple, d2: tuple, dt1: float, dt2: float) -> FlexureEstimate | None:
        p = self.params
        self._count("pairs")
        tol = p.dt_tolerance * dt1
        if abs(dt1 - dt2) > tol:
            self._count("bad_dt")
            return None
        t_start = t - dt1
        if self._x is None:
            self._x, self._P = self._initial()
            self._t_kf = self._t_att = t_start
        else:
            gap = t_start - self._t_att
            if gap < -tol:
                # Overlapping intervals: the stamps contradict the samples' dt.
                self._count("bad_dt")
                return None
            if gap > tol:
                self._count("gaps")
                if t_start - self._t_kf > p.max_gap_s:
                    self.reset(f"data gap of {gap:.3f} s exceeds max_gap_s")
                    self._x, self._P = self._initial()
                    self._t_kf = self._t_att = t_start
                else:
                    self._propagate(t_start)
                    self._reanchor()
                    self._t_att = t_start
        self._C1 = self._C1 @ dcm_from_rotation_vector(d1)
        self._C2 = self._C2 @ dcm_from_rotation_vector(d2)
        self._t_att = t
        self._n_att += 1
        if self._n_att % 1000 == 0:
            # Rounding drift of the products is ~1e-16 per step; renormalise well before it matters.
            self._C1 = orthonormalize(self._C1)
            self._C2 = orthonormalize(self._C2)
        if t - self._t_kf < p.filter_period_s - tol:
            return None
        return self._epoch(t)

    def _reanchor(self) -> None:
        """Restart both attitudes at I at the filter time (which must equal the attitude
        time) with θ_d := Φ_k + θ_k."""
        self._x, self._P = self._anchor(self._x, self._P)
        self._C1 = np.eye(3)
        self._C2 = np.eye(3)
        self._hold_attitudes()
        self._count("reanchors")

    def _propagate(self, t: float) -> None:
        """Time update from the filter time to ``t`` in whole nominal steps."""
        T = self.params.filter_period_s
        span = t - self._t_kf
        if span <= 0.0:
            return
        m = max(1, int(round(span / T)))
        h = span / m
        F, Q = self._model(h)
        self._couple_attitudes(F, h)
        x, P = self._x, self._P
        for _ in range(m):
            x, P = kalman.predict(x, P, F, Q)
        self._x, self._P = x, P
        self._t_kf = t
        self._hold_attitudes()

    def _couple_attitudes(self, F: np.ndarray, h: float) -> None:
        """Fill ``F``'s attitude-dependent block for a step ``h`` [s] (in place): the mean
        attitude over the interval for θ̇_d = Ĉ_i1b1 (ε1 − ε2)."""
        F[THETA_D, EPS] = (0.5 * h) * (self._C1_kf + self._C1)

    def _hold_attitudes(self) -> None:
        """Keep the attitudes at the filter time, the start of the next interval's mean."""
        self._C1_kf = self._C1

    def _observation(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``H`` at the current attitudes and the predicted observation h(X) (None: the
        paper's first order, H X)."""
        H = observation_matrix(self._C1, self._H)
        return H, predicted_observation(self._C1, self._x) if self.params.second_order_observation else None

    def _epoch(self, t: float) -> FlexureEstimate | None:
        self._propagate(t)
        # small_angles_from_dcm without its check: the DCMs are products of exact rotations
        # (renormalised every 1000 samples), and the check would cost 15 µs per step.
        z = match_attitudes(self._C1, self._C2)
        if not float(z @ z) < _MAX_MATCH_ANGLE ** 2:
            self.reset(f"attitude matching angle {math.sqrt(float(z @ z)):.4g} rad exceeds the small-angle limit")
            return None
        H, h_x = self._observation()
        up = kalman.joseph_update(self._x, self._P, z, H, self._R, self._gate, h_x)
        if up.accepted:
            self._x, self._P = up.x, up.P
        if not self._count_gate(up.accepted, up.d2):
            return None
        return self._output(t, up.y, up.d2, up.accepted)

    def _count_gate(self, accepted: bool, d2: float) -> bool:
        """The gate policy: count the update or the gated measurement; after
        ``max_gate_rejections`` in a row re-anchor, and reset if they go on. False when it reset."""
        if accepted:
            self._count("updates")
            self._rejections = 0
            self._gate_reanchored = False
            return True
        self._count("gated")
        self._rejections += 1
        if self._rejections >= self.params.max_gate_rejections:
            if self._gate_reanchored:
                self.reset(f"{self._rejections} consecutive measurements beyond the gate after a re-anchor "
                           f"(last d2 = {d2:.3g})")
                return False
            self._reanchor()
            self._gate_reanchored = True
            self._rejections = 0
        return True

    def _output(self, t: float, y: np.ndarray, d2: float, accepted: bool) -> FlexureEstimate:
        x, P = self._x, self._P
        dg = P.diagonal()
        var_tot = dg[PHI_K] + dg[THETA_K] + 2.0 * P[PHI_K, THETA_K].diagonal()
        sd = np.sqrt(dg)
        return FlexureEstimate(
            t, x[PHI_K] + x[THETA_K], np.sqrt(np.maximum(var_tot, 0.0)), x[PHI_K].copy(), sd[PHI_K],
            x[THETA_K].copy(), sd[THETA_K], x[EPS].copy(), sd[EPS], x[THETA_D].copy(), y, float(d2), bool(accepted),
        )
