"""Ship angular flexure by the *original* attitude matching of paper 5 eq. 1 (its ref. [10]):
the filter the simplified method of :mod:`.flexure_kf` replaces (docs/spec.md §3.5).

Observation (paper 5 eq. 1)
---------------------------
Both units integrate their attitudes from their own initial body frames, i1 = b1(t0) and
i2 = b2(t0), with initial DCMs I, exactly as in :mod:`.flexure_kf`. Eq. 1 reads

    Z = φ − A φ0 + Ĉ_i1b1ᵀ θr − Ĉ_i2b2ᵀ θr',

with φ the flexure at t_k, φ0 the flexure at t0 and θr, θr' the two units' own attitude
errors. The paper defines neither θr's sign nor A; both follow from re-deriving eq. 1.
With the INS attitude error on the left, as in eq. 2, ``Ĉ_ib = exp(−[θ×]) C_ib`` (θ in
the unit's i-frame), and ``C_i1i2 = exp([φ0×])``, ``C_b1b2 = exp([φ×])``:

    M = Ĉ_i1b1ᵀ Ĉ_i2b2 = exp([u×]) exp([φ×]),
    u = A (θr − θr' − φ0 + ½ (θr×θr' + θr×φ0 + θr'×φ0)),    A = Ĉ_i1b1ᵀ,

to second order, so ``Z = small_angles(M) = φ + u + ½ u×φ``, whose first order is eq. 1
with A = Ĉ_i1b1ᵀ ("derived from the two LGUs' DCMs": the paper's words allow any of Ĉ_i1b1ᵀ,
Ĉ_i2b2ᵀ or a mix, equal to O(φ)). The gain uses eq. 1's H,
``H = [I 0 I 0 −A A −Ĉ_i2b2ᵀ 0 0]``; with ``second_order_observation`` the innovation uses
:func:`predicted_observation` (the second-order form above), as :mod:`.flexure_kf` does for
the simplified one.

State (27) and dynamics
-----------------------
``X = [Φ_k, Φ_{k−1}, θ_k, θ_{k−1}, φ0, θr, θr', ε1, ε2]``, 3 each (roll, pitch, yaw):
φ = Φ + θ split as in paper 5 eq. 7 (quasi-static + dynamic), with the same quasi-static
models (random constant, or eq. 10's random-walk rate) and the same second-order Markov
dynamic flexure (eq. 12) as the simplified filter, so that the two differ only in the
attitude matching. Eq. 1 names φ, φ0, θr, θr'; the paper does not list ref. [10]'s states.
We take each unit's gyro bias as the driver of its attitude error (``θ̇r = −Ĉ_i1b1 ε1 + n1``,
``θ̇r' = −Ĉ_i2b2 ε2 + n2``, n the angle random walk) and each bias as a random walk (eq. 11
written per unit); φ0 is a random constant. To first order (Ĉ_i2b2ᵀ = A + O(φ)) Z sees
only φ0 − θr + θr' (the simplified filter's θ_d) and ε1 − ε2: the other 9 directions are
never observed, and carrying them is the computation the simplification removes (paper 5
§1-2). With per-unit bias priors and random walks of σ_diff/√2 (the default) the two
filters model the same flexure and estimate it alike.

Messages
--------
:class:`AttitudeMatchingKf` is a :class:`.flexure_kf.FlexureKf` with another state, model and
observation: it inherits the sample handling (rejection and counting of non-finite and
malformed samples; pairs taken from the edge; attitude integration; gaps, resets and the
gate) and its outputs (:class:`.flexure_kf.FlexureEstimate`, with
ε1 − ε2 as the bias difference and φ0 − θr + θr' as the relative attitude). Re-anchoring
starts new initial frames: φ0 := Φ_k + θ_k, θr = θr' := 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from gimbal_kinematics.maths.units import DEG, DEG_H
from gimbal_kinematics.maths.validate import nonneg_finite, of_type, per_axis, positive
from gimbal_kinematics.params.table import ParameterError

from gimbal_kinematics.maths import kalman
from .flexure_kf import THETA_D, FlexureEstimate, FlexureKf, FlexureKfParams

#: Slices of the state vector (the flexure states as in :mod:`.flexure_kf`).
PHI_K, PHI_K1, THETA_K, THETA_K1, PHI_0, THETA_R1, THETA_R2, EPS1, EPS2 = (
    slice(3 * i, 3 * i + 3) for i in range(9))
N_STATES = EPS2.stop
#: The flexure states [Φ_k, Φ_{k−1}, θ_k, θ_{k−1}].
FLEXURE = slice(PHI_K.start, THETA_K1.stop)
# φ0 takes θ_d's place, so that the simplified filter's anchoring applies to it.
assert PHI_0 == THETA_D


@dataclass(frozen=True)
class AttitudeMatchingParams(FlexureKfParams):
    """The simplified filter's parameters (same names and meaning: flexure models,
    measurement, gate, robustness) plus each unit's bias model.

    Attributes:
        lgu_bias_initial_sigma_deg_h: prior σ of each unit's gyro bias [°/h], scalar or
            (roll, pitch, yaw); None: ``bias_diff_initial_sigma_deg_h``/√2 (the same prior
            on ε1 − ε2 as the simplified filter).
        lgu_bias_rw_deg_h_rt_h: random walk of each unit's bias [°/h/√h]; None:
            ``bias_diff_rw_deg_h_rt_h``/√2.
    """

    lgu_bias_initial_sigma_deg_h: float | tuple[float, ...] | None = None
    lgu_bias_rw_deg_h_rt_h: float | tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for name, diff, strict in (("lgu_bias_initial_sigma_deg_h", self.bias_diff_initial_sigma_deg_h, True),
                                   ("lgu_bias_rw_deg_h_rt_h", self.bias_diff_rw_deg_h_rt_h, False)):
            value = getattr(self, name)
            if value is None:
                vals = tuple(x / math.sqrt(2.0) for x in diff)  # type: ignore[union-attr]
            else:
                vals = per_axis(name, value, 3)
                for x in vals:
                    (positive if strict else nonneg_finite)(name, x)
            object.__setattr__(self, name, vals)

    def simplified(self) -> FlexureKfParams:
        """The shared fields, as the simplified filter's parameters."""
        return FlexureKfParams(**_shared_fields(self))

    @classmethod
    def from_simplified(cls, p: FlexureKfParams, **bias: Any) -> AttitudeMatchingParams:
        """The original filter on the simplified one's parameters ``p`` (its flexure models,
        measurement, gate), with the per-unit bias fields ``bias`` (default: from σ_diff)."""
        return cls(**_shared_fields(p), **bias)

    @classmethod
    def from_values(cls, v: dict) -> AttitudeMatchingParams:
        """From a ``flexure_estimator`` node's values (:meth:`FlexureKfParams.from_values`'s
        names, plus the two per-unit bias names; absent or 0 means None).
        :class:`ParameterError` names the parameter refused."""
        base = FlexureKfParams.from_values(v)
        try:
            return cls.from_simplified(base, lgu_bias_initial_sigma_deg_h=v.get("lgu_bias_initial_sigma_deg_h") or None,
                                       lgu_bias_rw_deg_h_rt_h=v.get("lgu_bias_rw_deg_h_rt_h") or None)
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


def _shared_fields(p: FlexureKfParams) -> dict:
    return {f.name: getattr(p, f.name) for f in fields(FlexureKfParams)}


def observation_matrix(C_i1b1: np.ndarray, C_i2b2: np.ndarray) -> np.ndarray:
    """``H = [I 0 I 0 −A A −Ĉ_i2b2ᵀ 0 0]`` (3, 27), A = Ĉ_i1b1ᵀ (eq. 1)."""
    H = np.zeros((3, N_STATES))
    H[:, PHI_K] = np.eye(3)
    H[:, THETA_K] = np.eye(3)
    A = C_i1b1.T
    H[:, PHI_0] = -A
    H[:, THETA_R1] = A
    H[:, THETA_R2] = -C_i2b2.T
    return H


def predicted_observation(C_i1b1: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``h(X) = φ + u + ½ u×φ`` [rad], (3,): eq. 1 to second order (module docstring), with
    φ = Φ_k + θ_k and u = A(θr − θr' − φ0 + ½(θr×θr' + θr×φ0 + θr'×φ0))."""
    phi0, r1, r2 = x[PHI_0], x[THETA_R1], x[THETA_R2]
    w = r1 - r2 - phi0 + 0.5 * (_cross(r1, r2) + _cross(r1 + r2, phi0))
    u = C_i1b1.T @ w
    phi = x[PHI_K] + x[THETA_K]
    return phi + u + 0.5 * _cross(u, phi)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for (3,) vectors (np.cross costs several times more at this size)."""
    a0, a1, a2, b0, b1, b2 = float(a[0]), float(a[1]), float(a[2]), float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class AttitudeMatchingKf(FlexureKf):
    """Message-driven 27-state flexure filter by eq. 1 (module docstring): the calls,
    counters and outputs of :class:`.flexure_kf.FlexureKf`, whose message handling it
    inherits; ``state`` is (27,) and ``covariance`` (27, 27). Time is the messages' stamps."""

    def __init__(self, params: AttitudeMatchingParams | None = None) -> None:
        params = AttitudeMatchingParams() if params is None else params
        of_type("params", params, AttitudeMatchingParams)
        super().__init__(params)
        self.params: AttitudeMatchingParams = params
        # The simplified filter on the same fields: its flexure model and prior are ours.
        self._simplified = FlexureKf(params.simplified())
        self._q_arw = (params.lgu_arw_deg_rt_h * DEG / 60.0) ** 2  # each unit's [rad²/s]
        rw = params.lgu_bias_rw_deg_h_rt_h
        self._q_eps = np.array([(x * DEG_H / 60.0) ** 2 for x in rw])  # type: ignore[union-attr]
        # (Re-)anchoring: φ0 := Φ_k + θ_k, θr = θr' := 0, identity elsewhere; applied by the
        # inherited _anchor, which adds anchor_sigma_arcsec to φ0 (at θ_d's place).
        self._anchor_map = np.eye(N_STATES)
        for s in (PHI_0, THETA_R1, THETA_R2):
            self._anchor_map[s, s] = 0.0
        self._anchor_map[PHI_0, PHI_K] = np.eye(3)
        self._anchor_map[PHI_0, THETA_K] = np.eye(3)

    # ------------------------------------------------------------------ model
    def discrete_model(self, dt: float, C1_mean: np.ndarray | None = None,
                       C2_mean: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(F, Q)`` (27, 27) of one step ``dt`` [s]; ``F[θr, ε1] = −C̄1 dt`` and
        ``F[θr', ε2] = −C̄2 dt`` from the units' mean attitudes over the step (3, 3) when
        given, zero otherwise. Copies."""
        F, Q = self._model(dt)
        F = F.copy()
        F[THETA_R1, EPS1] = 0.0 if C1_mean is None else -dt * C1_mean
        F[THETA_R2, EPS2] = 0.0 if C2_mean is None else -dt * C2_mean
        return F, Q.copy()

    def _model(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Cached ``(F, Q)``; :meth:`_propagate` fills the attitude-dependent blocks in place.
        The flexure blocks are the simplified filter's."""
        key = round(dt * 1e6)  # stamp differences carry float noise far below 1 µs
        cached = self._model_cache.get(key)
        if cached is not None:
            return cached
        F = np.eye(N_STATES)
        Q = np.zeros((N_STATES, N_STATES))
        F_s, Q_s = self._simplified.discrete_model(dt)
        F[FLEXURE, FLEXURE], Q[FLEXURE, FLEXURE] = F_s[FLEXURE, FLEXURE], Q_s[FLEXURE, FLEXURE]
        Q[THETA_R1, THETA_R1] = Q[THETA_R2, THETA_R2] = self._q_arw * dt * np.eye(3)
        Q[EPS1, EPS1] = Q[EPS2, EPS2] = np.diag(self._q_eps * dt)
        if len(self._model_cache) > 16:
            self._model_cache.clear()
        self._model_cache[key] = (F, Q)
        return F, Q

    def _initial(self) -> tuple[np.ndarray, np.ndarray]:
        """The simplified filter's prior on the flexure, each unit's on its bias, then anchored."""
        P = np.zeros((N_STATES, N_STATES))
        P[FLEXURE, FLEXURE] = self._simplified._initial()[1][FLEXURE, FLEXURE]
        sigma = self.params.lgu_bias_initial_sigma_deg_h
        P[EPS1, EPS1] = P[EPS2, EPS2] = np.diag([(x * DEG_H) ** 2 for x in sigma])  # type: ignore[union-attr]
        x, P = self._anchor(np.zeros(N_STATES), P)
        return kalman.check_state(x, P, "AttitudeMatchingKf")

    # ------------------------------------------------------------------ steps
    def _clear(self) -> None:
        super()._clear()
        self._C2_kf = np.eye(3)

    def _couple_attitudes(self, F: np.ndarray, h: float) -> None:
        """Mean attitudes over the interval for θ̇r = −Ĉ_i1b1 ε1, θ̇r' = −Ĉ_i2b2 ε2."""
        F[THETA_R1, EPS1] = (-0.5 * h) * (self._C1_kf + self._C1)
        F[THETA_R2, EPS2] = (-0.5 * h) * (self._C2_kf + self._C2)

    def _hold_attitudes(self) -> None:
        self._C1_kf, self._C2_kf = self._C1, self._C2

    def _observation(self) -> tuple[np.ndarray, np.ndarray | None]:
        H = observation_matrix(self._C1, self._C2)
        return H, predicted_observation(self._C1, self._x) if self.params.second_order_observation else None

    def _output(self, t: float, y: np.ndarray, d2: float, accepted: bool) -> FlexureEstimate:
        """The simplified filter's output (the flexure states are laid out alike) with ε1 − ε2
        as the bias difference and φ0 − θr + θr' as the relative attitude."""
        x, P = self._x, self._P
        var_eps = P[EPS1, EPS1].diagonal() + P[EPS2, EPS2].diagonal() - 2.0 * P[EPS1, EPS2].diagonal()
        return super()._output(t, y, d2, accepted)._replace(
            bias_diff=x[EPS1] - x[EPS2], bias_diff_sigma=np.sqrt(np.maximum(var_eps, 0.0)),
            relative_attitude=x[PHI_0] - x[THETA_R1] + x[THETA_R2])
