"""Host INS output model (paper 1 §6): measured 3-2-1 Euler angles and body rates.

Attitude errors. Paper 1 gives only RMS figures (roll, pitch 0.05°; heading 0.2°) and
feeds the INS angles to its EKF as a white-noise measurement. Two models of them
(``attitude_model``):

* ``gauss_markov``: each Euler-angle error a first-order Gauss-Markov process with the
  paper's RMS and correlation time ``attitude_tau_s`` (τ → 0: the paper's literal white
  reading; ``inf``: a random constant per run).
* ``schuler``: what an INS's error model says its attitude error is (Titterton & Weston,
  *Strapdown Inertial Navigation Technology*, 2nd ed., §12.3; Savage, *Strapdown
  Analytics*, §14). Roll and pitch (tilt) errors oscillate at the Schuler period
  2π√(R/g) ≈ 84.4 min, driven by the accelerometer and gyro noise; an aided INS damps the
  loop. Each tilt error is a damped oscillator θ̈ + 2ζω_s θ̇ + ω_s² θ = w scaled to the
  paper's RMS (a second-order Gauss-Markov process, :func:`.markov.gm2_coefficients`);
  the heading error, with no Schuler coupling, wanders as a first-order Gauss-Markov
  process with ``attitude_tau_s``.

The error is added to the Euler angles themselves (not as a small rotation) because that is
how the paper states it; heading is wrapped to (-π, π]. Every sample draws its normals in
axis order (one per first-order axis, two per oscillator) from its own stream, and steps
through the compiled engine's kernel (:func:`.sensor_kernels.ins_attitude`).

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
from ._normals import NormalStream
from .gyro import PAPER1_INS_GYRO, GyroModel, GyroParams
from .markov import gm1_coefficients, gm2_coefficients
from .sensor_kernels import A_L11, A_P00, ins_attitude_error_step

ATTITUDE_MODELS = ("gauss_markov", "schuler")
# 2π√(R/g) with the mean earth radius 6 371 km and standard gravity 9.80665 m/s²
SCHULER_PERIOD_S = 5064.3


@dataclass(frozen=True)
class InsParams:
    """INS error parameters (validated, immutable).

    Attributes:
        roll_pitch_rms_deg: RMS of the roll and pitch errors [°].
        heading_rms_deg: RMS of the heading error [°].
        attitude_tau_s: correlation time [s] of the Gauss-Markov attitude errors (the heading's
            alone with ``schuler``) (> 0; inf = constant per run).
        attitude_model: ``gauss_markov`` or ``schuler`` (module docstring).
        schuler_period_s: the tilt oscillation's undamped period [s] (``schuler``).
        schuler_damping: its damping ratio ζ, in (0, 1) (``schuler``).
        gyro: body-rate error parameters of the INS gyro triad.
    """

    roll_pitch_rms_deg: float = 0.05
    heading_rms_deg: float = 0.2
    attitude_tau_s: float = 300.0
    attitude_model: str = "gauss_markov"
    schuler_period_s: float = SCHULER_PERIOD_S
    schuler_damping: float = 0.1
    gyro: GyroParams = field(default_factory=lambda: PAPER1_INS_GYRO)

    def __post_init__(self) -> None:
        v.nonneg_finite("roll_pitch_rms_deg", self.roll_pitch_rms_deg)
        v.nonneg_finite("heading_rms_deg", self.heading_rms_deg)
        v.positive("attitude_tau_s", self.attitude_tau_s, allow_inf=True)
        if self.attitude_model not in ATTITUDE_MODELS:
            raise ValueError(f"attitude_model must be one of {list(ATTITUDE_MODELS)}, got {self.attitude_model!r}")
        v.positive("schuler_period_s", self.schuler_period_s)
        if not 0.0 < self.schuler_damping < 1.0:
            raise ValueError(f"schuler_damping must be in (0, 1), got {self.schuler_damping}")
        if not isinstance(self.gyro, GyroParams):
            raise ValueError(f"gyro must be GyroParams, got {type(self.gyro).__name__}")


def _wrap_pi(a: float) -> float:
    """Angle in (-π, π]."""
    w = math.fmod(a + math.pi, 2.0 * math.pi)
    if w <= 0.0:
        w += 2.0 * math.pi
    return w - math.pi


class InsAttitudeError:
    """The INS's (roll, pitch, heading) errors of :class:`InsParams`' ``attitude_model``, in the
    kernel's arrays: ``state`` (3, 2) (θ, θ̇), ``coef`` (3, 7), ``order`` (3,); started from
    their stationary distribution.

    Args:
        params: the INS parameters.
        rng: the errors' own seeded Generator.
        dt: default step [s].
    """

    def __init__(self, params: InsParams, rng: np.random.Generator, dt: float) -> None:
        rp = params.roll_pitch_rms_deg * DEG
        self._sigma = (rp, rp, params.heading_rms_deg * DEG)
        self._params = params
        schuler = params.attitude_model == "schuler"
        self.order = np.array([2, 2, 1] if schuler else [1, 1, 1], dtype=np.int64)
        self.n_normals = int(self.order.sum())
        w0 = 2.0 * math.pi / params.schuler_period_s
        self._beta, self._freq = params.schuler_damping * w0, w0 * math.sqrt(1.0 - params.schuler_damping ** 2)
        self._normals = NormalStream(rng)
        self.state = np.zeros((3, 2))
        z, j = self._normals.take(self.n_normals)
        for i in range(3):
            self.state[i, 0] = self._sigma[i] * z[j]
            if self.order[i] == 2:
                self.state[i, 1] = w0 * self._sigma[i] * z[j + 1]
            j += int(self.order[i])
        self.coef = np.zeros((3, 7))
        self._dt = -1.0
        self._set_dt(dt)

    def _set_dt(self, dt: float) -> None:
        v.positive("dt", dt)
        for i in range(3):
            if self.order[i] == 2:
                self.coef[i] = gm2_coefficients(self._beta, self._freq, self._sigma[i], dt)
            else:
                self.coef[i, A_P00], self.coef[i, A_L11] = gm1_coefficients(self._sigma[i], self._params.attitude_tau_s,
                                                                            dt)
        self._dt = dt

    def step(self, dt: float | None = None) -> np.ndarray:
        """Advance by ``dt`` [s] (default: the constructor's); the new (roll, pitch, heading) errors (3,)."""
        if dt is not None and dt != self._dt:
            self._set_dt(dt)
        z, j = self._normals.take(self.n_normals)
        ins_attitude_error_step(self.state, self.coef, self.order, np.asarray(z[j:j + self.n_normals]))
        return self.state[:, 0].copy()


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
        self._attitude = InsAttitudeError(params, rng_att, dt)
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
        return self._attitude.state[:, 0].copy()

    @property
    def true_gyro_bias(self) -> np.ndarray:
        """Current total body-rate bias [rad/s], (3,)."""
        return self.gyro.true_bias

    def true_gyro_bias_values(self) -> tuple[float, ...]:
        """:attr:`true_gyro_bias` as a tuple of floats."""
        return self.gyro.true_bias_values()
