"""Paper 2's closed-loop complementary Kalman filter for one gimbal axis (encoder + gyro).

Re-derived state meaning
------------------------
The gyro measures ω_g = (1 + s) ω + b + n (scale-factor error s, bias b, noise n); the
encoder-derived velocity measures ω_e = ω + v (pulse-count quantisation, paper 2 eq. 1).
The loop feeds back the *corrected* gyro velocity ω̂ = ω_g + c, where c is the correction
accumulated by the error updater. The filter state is::

    x1 = ω − ω̂        velocity error of the corrected gyro [rad/s]
    x2 = −s            gyro scale-factor correction [-]
    x3 = −ḃ            gyro bias drift-rate correction [rad/s²]

From one sample to the next x1 changes by −s Δω − Δb ≈ x2 Δψ_g + x3 T, where Δψ_g is the
change of the gyro velocity between the samples (paper 2: "a change of angular velocity
between kT and (k−1)T, from gyroscope") and T the sample period, hence paper 2's eq. 4,

    Φ = [[1, Δψ_g, T], [0, 1, 0], [0, 0, 1]],     z = ω_e − ω̂ = x1 + v,   H = [1 0 0].

Closed loop (paper 2 eq. 2, x(k+1) = Φ x(k) + w − δx̂(k)): after every update the velocity
estimate x̂1 is handed to the error updater, which accumulates it into c (c ← c + x̂1), and
is removed from the state (δx̂ = [x̂1, 0, 0]). The scale and drift-rate estimates stay in the
state; through Φ they keep adding Δψ_g x̂2 + T x̂3 to x1, which the next update feeds into c.
A constant gyro bias b therefore ends up in c (c → −b): "the accumulated error estimate"
that corrects the feedback velocity. Feedback does not change the estimation-error
covariance, so P is propagated and updated as in the open-loop filter (Joseph form,
:func:`gimbal_estimators.kalman.joseph_update`).

Process noise. Continuous white noises drive x1 (bias random walk, density q1), x2
(scale random walk, q2) and x3 (drift-rate random walk, q3); over a step T, with x3
integrated into x1 (the Δψ_g coupling of q2 is neglected, it is second order)::

    Q = [[q1 T + q3 T³/3, 0, q3 T²/2], [0, q2 T, 0], [q3 T²/2, 0, q3 T]]

Measurement noise R: the pulse-count velocity error over a gate T_g is the difference of
two angle quantisation errors (uniform, width δ), σ_v = δ / (T_g √6). Consecutive gates
share an end point, so the noise is negatively correlated (MA(1)); the filter treats it as
white, which only makes it slightly conservative (the counts telescope, see the tests).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_estimators.kalman import check_state, joseph_update

_DEG = math.pi / 180.0
_H = np.array([[1.0, 0.0, 0.0]])
_H.flags.writeable = False


def _positive(name: str, value: float, allow_zero: bool = False) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if value < 0.0 or (value == 0.0 and not allow_zero):
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {value}")


@dataclass(frozen=True)
class FusionKfParams:
    """Q, R and the initial covariance of the complementary filter (units in the names).

    Attributes:
        q_velocity_deg_s_rt_s: bias random-walk density driving x1 [°/s/√s].
        q_scale_rt_s: scale-factor random-walk density driving x2 [1/√s].
        q_drift_deg_s2_rt_s: drift-rate random-walk density driving x3 [°/s²/√s].
        r_deg_s: σ of the encoder-minus-gyro velocity measurement [°/s].
        p0_velocity_deg_s: initial σ of x1 (the unknown gyro bias) [°/s].
        p0_scale: initial σ of x2 [-].
        p0_drift_deg_s2: initial σ of x3 [°/s²].
        gate_sigma: innovations beyond this many σ are rejected (inf = no gate).
    """

    q_velocity_deg_s_rt_s: float = 2e-3
    q_scale_rt_s: float = 1e-5
    q_drift_deg_s2_rt_s: float = 1e-5
    r_deg_s: float = 0.72
    p0_velocity_deg_s: float = 0.5
    p0_scale: float = 0.01
    p0_drift_deg_s2: float = 1e-3
    gate_sigma: float = math.inf

    def __post_init__(self) -> None:
        for name in ("q_velocity_deg_s_rt_s", "q_scale_rt_s", "q_drift_deg_s2_rt_s"):
            _positive(name, getattr(self, name), allow_zero=True)
        for name in ("r_deg_s", "p0_velocity_deg_s", "p0_scale", "p0_drift_deg_s2"):
            _positive(name, getattr(self, name))
        g = self.gate_sigma
        if isinstance(g, bool) or not isinstance(g, (int, float)) or math.isnan(g) or g <= 0.0:
            raise ValueError(f"gate_sigma must be > 0 (inf for no gate), got {g!r}")

    @property
    def q_density(self) -> tuple[float, float, float]:
        """(q1, q2, q3) power spectral densities in SI: rad²/s³, 1/s, rad²/s⁵."""
        return ((self.q_velocity_deg_s_rt_s * _DEG) ** 2, self.q_scale_rt_s ** 2,
                (self.q_drift_deg_s2_rt_s * _DEG) ** 2)

    @property
    def r_rad2_s2(self) -> float:
        return (self.r_deg_s * _DEG) ** 2

    def initial_covariance(self) -> np.ndarray:
        """P0, shape (3, 3), diagonal [rad²/s², -, rad²/s⁴]."""
        return np.diag([(self.p0_velocity_deg_s * _DEG) ** 2, self.p0_scale ** 2,
                        (self.p0_drift_deg_s2 * _DEG) ** 2])


def transition(T: float, dpsi_g: float) -> np.ndarray:
    """Φ of paper 2 eq. 4 for a step ``T`` [s] and gyro velocity change ``dpsi_g`` [rad/s]."""
    return np.array([[1.0, dpsi_g, T], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def process_noise(T: float, q: tuple[float, float, float]) -> np.ndarray:
    """Q over a step ``T`` [s] for densities ``q`` = (q1, q2, q3) (module docstring)."""
    q1, q2, q3 = q
    return np.array([[q1 * T + q3 * T ** 3 / 3.0, 0.0, q3 * T * T / 2.0],
                     [0.0, q2 * T, 0.0],
                     [q3 * T * T / 2.0, 0.0, q3 * T]])


class ClosedLoopComplementaryKf:
    """One axis of paper 2's filter plus its error updater (module docstring).

    ``x`` (3,), ``P`` (3, 3); ``correction`` c [rad/s] is what the loop adds to the gyro
    velocity. Call :meth:`predict` then :meth:`update` once per encoder velocity sample.
    """

    def __init__(self, params: FusionKfParams | None = None, name: str = "fusion_kf") -> None:
        self.params = params if params is not None else FusionKfParams()
        if not isinstance(self.params, FusionKfParams):
            raise ValueError("params must be a FusionKfParams")
        self.name = name
        self._q = self.params.q_density
        self._R = np.array([[self.params.r_rad2_s2]])
        self._gate_d2 = self.params.gate_sigma ** 2
        self.reset()

    def reset(self, correction: float = 0.0) -> None:
        """Back to the prior: x = 0, P = P0; the accumulated correction is set to
        ``correction`` [rad/s]."""
        self.x, self.P = check_state(np.zeros(3), self.params.initial_covariance(), self.name)
        self.correction = float(correction)
        self.updates = 0
        self.rejected = 0
        self.last_innovation = 0.0

    @property
    def scale_correction(self) -> float:
        """x̂2 = −(gyro scale-factor error) [-]."""
        return float(self.x[1])

    @property
    def drift_rate_correction(self) -> float:
        """x̂3 = −(gyro bias drift rate) [rad/s²]."""
        return float(self.x[2])

    def predict(self, T: float, dpsi_g: float) -> None:
        """x ← Φ x, P ← Φ P Φᵀ + Q over ``T`` [s] with gyro velocity change ``dpsi_g`` [rad/s]."""
        F = transition(T, dpsi_g)
        self.x = F @ self.x
        self.P = F @ self.P @ F.T + process_noise(T, self._q)
        self.P = 0.5 * (self.P + self.P.T)

    def update(self, z: float) -> bool:
        """Fuse z = ω_e − ω̂ [rad/s] (Joseph form), then feed x̂1 back into the correction.
        Returns False (state untouched, counted) when the innovation gate rejects z."""
        up = joseph_update(self.x, self.P, np.array([z]), _H, self._R, self._gate_d2)
        self.last_innovation = float(up.y[0])
        if not up.accepted:
            self.rejected += 1
            return False
        self.x, self.P = up.x, up.P
        self.updates += 1
        # error updater: δx̂ = [x̂1, 0, 0] goes into c and out of the state
        self.correction += float(self.x[0])
        self.x[0] = 0.0
        return True

    def kalman_gain(self, T: float, dpsi_g: float = 0.0) -> np.ndarray:
        """Gain (3,) the next update would use after a predict over ``T`` (no side effects)."""
        F = transition(T, dpsi_g)
        P = F @ self.P @ F.T + process_noise(T, self._q)
        return P[:, 0] / (P[0, 0] + self._R[0, 0])
