"""Two ring-laser-gyro units across a flexing hull (paper 5): LGU1 near the master INS,
LGU2 at a peripheral device.

LGU1 senses the ship body rate ``ω_ib1^b1``. LGU2's frame is b2 = b1 turned by the
flexure rotation vector θ (:mod:`.flexure`): ``C_b1b2 = exp([θ×])`` (≈ I + [θ×], paper 5
eq. 4), so ``C_b2b1 = exp(-[θ×])`` and, exactly,

    ω_ib2^b2 = C_b2b1 ω_ib1^b1 + J_r(θ) θ̇,

J_r the right Jacobian of SO(3). We keep terms to second order in θ:

    C_b2b1 ω ≈ ω - θ×ω + ½ θ×(θ×ω),   J_r(θ) θ̇ ≈ θ̇ - ½ θ×θ̇.

(The first-order form ``ω - θ×ω + θ̇`` drifts by ~1″ over minutes of 3-5° ship motion
with |θ| ≈ 0.2°, because ½θ×(θ×ω) does not average out; the second-order form stays
below 0.01″, checked against exact rotations in the tests.) Per step we use the
increment form with θ_m the mean of the flexure at the ends of the step and Δθ its
exact change:

    Δα2 = Δα1 - θ_m×Δα1 + ½ θ_m×(θ_m×Δα1) + Δθ - ½ θ_m×Δθ.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gimbal_kinematics.maths.validate import of_type

from .flexure import ShipFlexureTruth
from .gyro import LGU1_GYRO, LGU2_GYRO, GyroModel, GyroParams


def lgu2_rate(
    omega_ib1_b1: Sequence[float], theta: Sequence[float], theta_dot: Sequence[float]
) -> list[float]:
    """``ω_ib2^b2 = exp(-[θ×]) ω_ib1^b1 + J_r(θ) θ̇`` to second order in θ [rad/s], (3,).

    Args: LGU1 rate ω_ib1^b1 [rad/s], flexure θ [rad], flexure rate θ̇ [rad/s]; each (3,).
    """
    return _flexed(omega_ib1_b1, theta, theta_dot)


def _cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _flexed(v1: Sequence[float], th: Sequence[float], dth: Sequence[float]) -> list[float]:
    """``v1 - θ×v1 + ½ θ×(θ×v1) + dθ - ½ θ×dθ`` (rate or increment form), (3,)."""
    c1 = _cross(th, v1)
    c2 = _cross(th, c1)
    c3 = _cross(th, dth)
    return [v1[i] - c1[i] + 0.5 * c2[i] + dth[i] - 0.5 * c3[i] for i in range(3)]


class LguPair:
    """LGU1 and LGU2 incremental-angle outputs; owns the stepping of ``flexure``.

    Args:
        flexure: the flexure truth between b1 and b2 (advanced by :meth:`step`).
        rng: the run's seeded Generator; one child stream is spawned per LGU.
        dt: default step [s].
        lgu1, lgu2: gyro parameters (paper 5: fixed biases +0.05 °/h and -0.05 °/h).
    """

    def __init__(
        self,
        flexure: ShipFlexureTruth,
        rng: np.random.Generator,
        dt: float,
        lgu1: GyroParams = LGU1_GYRO,
        lgu2: GyroParams = LGU2_GYRO,
    ) -> None:
        of_type("flexure", flexure, ShipFlexureTruth)
        of_type("rng", rng, np.random.Generator, "a numpy.random.Generator")
        self.flexure = flexure
        rng1, rng2 = rng.spawn(2)
        self.lgu1 = GyroModel(lgu1, 3, rng1, dt)
        self.lgu2 = GyroModel(lgu2, 3, rng2, dt)
        self.dt = dt
        #: True LGU2 increment of the latest step [rad], (3,).
        self.true_increment_b2 = [0.0, 0.0, 0.0]
        # The flexure at the start of the next step; cached because this object is the
        # only one that advances ``flexure``.
        self._theta = flexure.angle

    def step(self, dalpha_b1_true: Sequence[float], dt: float | None = None) -> tuple[list[float], list[float]]:
        """Advance one step.

        Args:
            dalpha_b1_true: true LGU1 incremental angle over the step [rad], (3,)
                (ω_ib1^b1 integrated over the step).
            dt: step [s] (default: the constructor's).

        Returns:
            ``(dalpha1_meas, dalpha2_meas)``: measured incremental angles [rad], (3,) each.
        """
        h = self.dt if dt is None else dt
        th0 = self._theta
        self.flexure.step(h)
        th1 = self._theta = self.flexure.angle
        mid = [0.5 * (th0[i] + th1[i]) for i in range(3)]
        d2 = _flexed(dalpha_b1_true, mid, [th1[i] - th0[i] for i in range(3)])
        self.true_increment_b2 = d2
        inv = 1.0 / h
        m1 = self.lgu1.step_increment([a * inv for a in dalpha_b1_true], h)
        m2 = self.lgu2.step_increment([d2[0] * inv, d2[1] * inv, d2[2] * inv], h)
        return m1, m2
