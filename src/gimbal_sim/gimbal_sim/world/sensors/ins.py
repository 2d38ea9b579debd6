"""Host INS output model (paper 1 §6): measured 3-2-1 Euler angles and body rates.

Attitude errors. Paper 1 gives only RMS figures (roll, pitch 0.05°; heading 0.2°) and
feeds the INS angles to its EKF as a white-noise measurement. A real INS attitude error is
not white: it is dominated by Schuler-period (84 min) and slow heading errors. We model
each Euler-angle error as a first-order Gauss-Markov process with the paper's RMS and a
correlation time ``attitude_tau_s`` (default 300 s: slowly varying, nearly constant over
paper 1's 120 s runs, but not frozen); ``attitude_tau_s = inf`` gives a random constant
per run. The error is added to the Euler angles themselves (not as a small rotation)
because that is how the paper states it; heading is wrapped to (-π, π].

Body-rate errors come from a 3-axis :class:`GyroModel` (paper 1: 1 °/h fixed, 1 °/h
Gauss-Markov τ = 60 s, ARW 0.1 °/√h).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import DEG
from .gyro import PAPER1_INS_GYRO, GyroModel, GyroParams
from .markov import FirstOrderGaussMarkov


@dataclass(frozen=True)
class InsParams:
    """INS error parameters (validated, immutable).

    Attributes:
        roll_pitch_rms_deg: RMS of the roll and pitch errors [°].
        heading_rms_deg: RMS of the heading error [°].
        attitude_tau_s: correlation time of the attitude errors [s] (> 0; inf = constant per run).
        gyro: body-rate error parameters of the INS gyro triad.
    """

    roll_pitch_rms_deg: float = 0.05
    heading_rms_deg: float = 0.2
    attitude_tau_s: float = 300.0
    gyro: GyroParams = field(default_factory=lambda: PAPER1_INS_GYRO)

    def __post_init__(self) -> None:
        v.nonneg_finite("roll_pitch_rms_deg", self.roll_pitch_rms_deg)
        v.nonneg_finite("heading_rms_deg", self.heading_rms_deg)
        v.positive("attitude_tau_s", self.attitude_tau_s, allow_inf=True)
        if not isinstance(self.gyro, GyroParams):
            raise ValueError(f"gyro must be GyroParams, got {type(self.gyro).__name__}")


def _wrap_pi(a: float) -> float:
    """Angle in (-π, π]."""
    w = math.fmod(a + math.pi, 2.0 * math.pi)
    if w <= 0.0:
        w += 2.0 * math.pi
    return w - math.pi


class InsModel:
    """Measured INS attitude and body rates.

    Args:
        params: error parameters.
        rng: the run's seeded Generator; two independent child streams are spawned from it
            (attitude errors, gyro triad).
        dt: default step [s].
    """

    def __init__(self, params: InsParams, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, InsParams)
        v.of_type("rng", rng, np.random.Generator, "a numpy.random.Generator")
        self.params = params
        rng_att, rng_gyro = rng.spawn(2)
        rp = params.roll_pitch_rms_deg * DEG
        self._attitude = FirstOrderGaussMarkov(
            (rp, rp, params.heading_rms_deg * DEG), params.attitude_tau_s, rng_att, dt
        )
        self.gyro = GyroModel(params.gyro, 3, rng_gyro, dt)

    def step(
        self, euler_true: Sequence[float], omega_b_true: Sequence[float], dt: float | None = None
    ) -> tuple[list[float], list[float]]:
        """Advance one step and return ``(euler_meas, omega_b_meas)``.

        Args:
            euler_true: true (roll φ, pitch θ, yaw ψ) [rad] at the end of the step, (3,).
            omega_b_true: true body inertial rates (p, q, r) [rad/s] averaged over the step, (3,).
            dt: step [s] (default: the constructor's).

        Returns:
            Measured Euler angles (3,) [rad] (yaw in (-π, π]) and body rates (3,) [rad/s].
        """
        err = self._attitude.step(dt)
        euler = [euler_true[0] + err[0], euler_true[1] + err[1], _wrap_pi(euler_true[2] + err[2])]
        return euler, self.gyro.step_rate(omega_b_true, dt)

    @property
    def attitude_error(self) -> np.ndarray:
        """Current (roll, pitch, yaw) error [rad] applied to the latest output, (3,)."""
        return self._attitude.value

    @property
    def true_gyro_bias(self) -> np.ndarray:
        """Current total body-rate bias [rad/s], (3,)."""
        return self.gyro.true_bias

    def true_gyro_bias_values(self) -> tuple[float, ...]:
        """:attr:`true_gyro_bias` as a tuple of floats."""
        return self.gyro.true_bias_values()
