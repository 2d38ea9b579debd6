"""Paper 2's closed-loop complementary Kalman filter for one gimbal axis (encoder + gyro).

Re-derived state meaning
------------------------
Paper 2 eq. 4 gives Φ = [[1, Δψ_g, T], [0, 1, 0], [0, 0, 1]] and H = [1 0 0], with Δψ_g
"a change ... between kT and (k−1)T, from gyroscope". Row 1 adds Δψ_g·x2 and T·x3 to x1.
It is dimensionally consistent when x1 is an angle, Δψ_g the gyro's *angle increment*
over the step (ψ is an angle) with x2 its scale-factor error, and x3 a rate, the gyro drift,
multiplied by the step T. (Read as a velocity error, x3 would have to be a drift
*acceleration*, and the filter could only estimate velocity: it would leave a permanent
LOS offset equal to the bias integrated while it converged. In the 20 s prototype of the
UAV experiment that reading gave about 5 mrad RMS; this form gives about 0.7 mrad.)

The gyro measures ω_g = (1 + s) ω + b + n (scale-factor error s, bias/drift b, noise n).
The loop feeds back the corrected velocity

    ω̂ = ω_g (1 + S) + E + A,

where S and E are the scale and drift corrections accumulated by the error updater, and A
spreads the latest angle correction over the next step. ψ̂ = ∫ω̂ dt is the angle the loop
holds: the PID integrates the velocity error. The state is::

    x1 = ψ − ψ̂              angle error of the integrated, corrected gyro rate [rad]
    x2 = −(s + S)           residual scale-factor correction [-]
    x3 = −(b + E)           residual drift correction [rad/s]

so x1 grows by x2 Δψ_g + x3 T per step, which is paper 2's Φ. The measurement is the
encoder rate minus the corrected gyro rate, integrated: z = ψ_enc − ψ̂ = x1 + v, with H = [1 0 0].
Here ψ_enc is the encoder-derived angle (pulse counts plus the base motion about the axis),
so v is the angle quantisation, uniform of width δ, with σ_v = δ/√12 for a single count.
Averaging over a gate while the joint moves makes it smaller.

Closed loop, paper 2 eqs. 2 and 6 (x(k+1) = Φ x(k) + w − δx̂(k)). After every update the
whole estimate goes to the error updater: S += x̂2, E += x̂3, and x̂1 is applied as the rate
A = x̂1/T over the next step. Over that step these corrections remove exactly Φ x̂ from
the error, so δx̂ = Φ x̂ and the predicted state is zero. That is the usual feedback
filter: each measurement is the residual error accumulated since the last correction.
Feeding back known quantities does not change the estimation-error covariance, so P is
propagated and updated as in the open-loop filter, with the Joseph update
:func:`gimbal_kinematics.maths.kalman.joseph_update`. The accumulated drift correction E is
"the accumulated error estimate" that corrects the feedback velocity. With a constant
bias b, E → −b: the bias no longer shows in ω̂.

Process noise: continuous white noises drive x1 (gyro angle random walk, density q1),
x2 (scale random walk, q2) and x3 (bias random walk, q3). Over a step T, with x3
integrated into x1 and the Δψ_g coupling of q2 neglected (it is second order)::

    Q = [[q1 T + q3 T³/3, 0, q3 T²/2], [0, q2 T, 0], [q3 T²/2, 0, q3 T]]
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.maths.kalman import check_state, joseph_update
from gimbal_kinematics.maths.units import DEG
from gimbal_kinematics.maths.validate import nonneg_finite, positive

#: State indices (module docstring): x1 the angle error, x2 the residual scale-factor
#: correction, x3 the residual drift correction.
ANGLE, SCALE, DRIFT = 0, 1, 2
N_STATES = 3
#: H = [1 0 0]: the encoder measures the angle error.
_H = np.zeros((1, N_STATES))
_H[0, ANGLE] = 1.0
_H.flags.writeable = False


@dataclass(frozen=True)
class FusionKfParams:
    """Q, R and the initial covariance of the complementary filter (units in the names).

    Defaults suit the MEMS gyro and 1024-line encoders of the paper 2 experiment.

    Attributes:
        q_angle_deg_rt_s: gyro angle-random-walk density driving x1 [°/√s]
            (0.2 °/√h = 3.3e-3 °/√s).
        q_scale_rt_s: scale-factor random-walk density driving x2 [1/√s].
        q_drift_deg_s_rt_s: bias random-walk density driving x3 [°/s/√s] (a Gauss-Markov
            bias of σ over τ is about σ √(2/τ): 0.02 °/s over 60 s -> 3.7e-3).
        r_deg: σ of z, the encoder-minus-gyro angle [°]. One count of 1024 lines gives
            δ/√12 = 0.101°. The experiment's z, averaged over a 0.2 s gate while the joint
            moves, measured about 0.03° (innovation statistics).
        p0_angle_deg: initial σ of x1 [°].
        p0_scale: initial σ of x2 [-].
        p0_drift_deg_s: initial σ of x3, the unknown turn-on bias [°/s].
        gate_sigma: innovations beyond this many σ are rejected (inf = no gate).
    """

    q_angle_deg_rt_s: float = 3.3e-3
    q_scale_rt_s: float = 1e-5
    q_drift_deg_s_rt_s: float = 4e-3
    r_deg: float = 0.03
    p0_angle_deg: float = 0.1
    p0_scale: float = 0.01
    p0_drift_deg_s: float = 0.3
    gate_sigma: float = math.inf

    def __post_init__(self) -> None:
        for name in ("q_angle_deg_rt_s", "q_scale_rt_s", "q_drift_deg_s_rt_s"):
            nonneg_finite(name, getattr(self, name))
        for name in ("r_deg", "p0_angle_deg", "p0_scale", "p0_drift_deg_s"):
            positive(name, getattr(self, name))
        g = self.gate_sigma
        if isinstance(g, bool) or not isinstance(g, (int, float)) or math.isnan(g) or g <= 0.0:
            raise ValueError(f"gate_sigma must be > 0 (inf for no gate), got {g!r}")

    @property
    def q_density(self) -> tuple[float, float, float]:
        """(q1, q2, q3) power spectral densities in SI: rad²/s, 1/s, rad²/s³."""
        return ((self.q_angle_deg_rt_s * DEG) ** 2, self.q_scale_rt_s ** 2,
                (self.q_drift_deg_s_rt_s * DEG) ** 2)

    @property
    def r_rad2(self) -> float:
        """R [rad²]."""
        return (self.r_deg * DEG) ** 2

    def initial_covariance(self) -> np.ndarray:
        """P0, shape (3, 3), diagonal [rad², -, rad²/s²]."""
        P0 = np.zeros((N_STATES, N_STATES))
        P0[ANGLE, ANGLE] = (self.p0_angle_deg * DEG) ** 2
        P0[SCALE, SCALE] = self.p0_scale ** 2
        P0[DRIFT, DRIFT] = (self.p0_drift_deg_s * DEG) ** 2
        return P0


def transition(T: float, dpsi_g: float) -> np.ndarray:
    """Φ of paper 2 eq. 4, shape (3, 3): step ``T`` [s], gyro angle increment ``dpsi_g`` [rad]."""
    F = np.eye(N_STATES)
    F[ANGLE, SCALE] = dpsi_g
    F[ANGLE, DRIFT] = T
    return F


def process_noise(T: float, q: tuple[float, float, float]) -> np.ndarray:
    """Q over a step ``T`` [s] for densities ``q`` = (q1, q2, q3) (module docstring)."""
    q1, q2, q3 = q
    Q = np.zeros((N_STATES, N_STATES))
    Q[ANGLE, ANGLE] = q1 * T + q3 * T ** 3 / 3.0
    Q[ANGLE, DRIFT] = Q[DRIFT, ANGLE] = q3 * T * T / 2.0
    Q[SCALE, SCALE] = q2 * T
    Q[DRIFT, DRIFT] = q3 * T
    return Q


class ClosedLoopComplementaryKf:
    """One axis of paper 2's filter with its error updater (module docstring).

    ``x`` (3,) and ``P`` (3, 3) are the residual state and its covariance. The error
    updater holds ``scale_correction`` S [-], ``drift_correction`` E [rad/s] and
    ``pending_angle`` [rad], the angle still to be applied over the next step. Per
    measurement step: :meth:`predict` (T, Δψ_g of the step just ended), then
    :meth:`update` (z); between the updates the loop uses :meth:`corrected_rate`.
    """

    def __init__(self, params: FusionKfParams | None = None, name: str = "fusion_kf") -> None:
        self.params = params if params is not None else FusionKfParams()
        if not isinstance(self.params, FusionKfParams):
            raise ValueError("params must be a FusionKfParams")
        self.name = name
        self._q = self.params.q_density
        self._R = np.array([[self.params.r_rad2]])
        self._gate_d2 = self.params.gate_sigma ** 2
        self.reset()

    def reset(self) -> None:
        """Back to the prior: x = 0, P = P0, no corrections."""
        self.x, self.P = check_state(np.zeros(N_STATES), self.params.initial_covariance(), self.name)
        self._fed = np.zeros(N_STATES)  # δx̂ handed to the error updater at the last update
        self.scale_correction = 0.0
        self.drift_correction = 0.0
        self.pending_angle = 0.0
        self.updates = 0
        self.rejected = 0
        self.last_innovation = 0.0

    def corrected_rate(self, omega_g: float, step_s: float) -> float:
        """ω̂ = ω_g (1 + S) + E + pending_angle / ``step_s`` [rad/s]. ``step_s`` is the
        length of the step the pending angle is spread over [s]."""
        return omega_g * (1.0 + self.scale_correction) + self.drift_correction + self.pending_angle / step_s

    def predict(self, T: float, dpsi_g: float) -> None:
        """x ← Φ x − δx̂, P ← Φ P Φᵀ + Q over the step just ended: ``T`` [s], raw gyro angle
        increment ``dpsi_g`` [rad]. δx̂ = Φ x̂_fed, what the corrections removed."""
        F = transition(T, dpsi_g)
        self.x = F @ (self.x - self._fed)
        self.P = F @ self.P @ F.T + process_noise(T, self._q)
        self.P = 0.5 * (self.P + self.P.T)
        self._fed = np.zeros(N_STATES)
        self.pending_angle = 0.0

    def update(self, z: float) -> bool:
        """Fuse z = ψ_enc − ψ̂ [rad] (Joseph form), then hand x̂ to the error updater.
        Returns False (state untouched, counted) when the innovation gate rejects z."""
        up = joseph_update(self.x, self.P, np.array([z]), _H, self._R, self._gate_d2)
        self.last_innovation = float(up.y[0])
        if not up.accepted:
            self.rejected += 1
            return False
        self.x, self.P = up.x, up.P
        self.updates += 1
        self.scale_correction += float(self.x[SCALE])
        self.drift_correction += float(self.x[DRIFT])
        self.pending_angle = float(self.x[ANGLE])
        self._fed = self.x.copy()
        return True

    def kalman_gain(self, T: float, dpsi_g: float = 0.0) -> np.ndarray:
        """Gain (3,) the next update would use after a predict over ``T`` (no side effects)."""
        F = transition(T, dpsi_g)
        P = F @ self.P @ F.T + process_noise(T, self._q)
        return P[:, ANGLE] / (P[ANGLE, ANGLE] + self._R[0, 0])
