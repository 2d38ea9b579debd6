"""Accelerometer error model (paper 3: 100 µg grade), on the shared inertial error core.

Terms: fixed bias (given and/or drawn per run), optional Gauss-Markov bias instability,
white noise (velocity random walk), scale-factor error, its asymmetry and the small-angle
axis misalignment (each given and/or drawn per run, the gyro's model: :mod:`.inertial_core`);
n = 3 for a triad or 2 for the level pair of paper 3's alignment. Output as step-average
specific force [m/s²] or velocity increment [m/s].
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import UG_G0, UG_RT_HZ
from .inertial_core import (ErrorSpecSI, InertialErrorCore, axis_errors_si, bias_terms_si, check_axis_errors,
                            check_bias_terms)


@dataclass(frozen=True)
class AccelerometerParams:
    """Accelerometer error parameters in engineering units (validated, immutable).

    Attributes:
        bias_ug: given fixed bias [µg], scalar or per axis.
        bias_sigma_ug: σ of a run-to-run bias drawn once per run [µg].
        bias_instability_ug: Gauss-Markov bias instability RMS [µg].
        bias_instability_tau_s: its correlation time [s] (> 0; inf = random constant).
        noise_ug_rt_hz: white noise density [µg/√Hz] (step-average σ = density/√Δt).
        scale_factor_ppm: given scale-factor error s [ppm], scalar or per axis.
        scale_factor_sigma_ppm: σ of a run-to-run scale-factor error drawn per axis and added [ppm].
        scale_asymmetry_ppm: given scale-factor asymmetry A = K+ − K− [ppm], scalar or per axis:
            the scale factor is 1 + s + A/2 for a positive input, 1 + s − A/2 for a negative one.
        scale_asymmetry_sigma_ppm: σ of a run-to-run asymmetry drawn per axis and added [ppm].
        misalignment_rad: (n, n) small-angle cross-coupling, zero diagonal [rad], or None.
        misalignment_sigma_urad: σ of a run-to-run draw added to each off-diagonal element [µrad].
    """

    bias_ug: float | tuple[float, ...] = 0.0
    bias_sigma_ug: float = 0.0
    bias_instability_ug: float = 0.0
    bias_instability_tau_s: float = math.inf
    noise_ug_rt_hz: float = 0.0
    scale_factor_ppm: float | tuple[float, ...] = 0.0
    scale_factor_sigma_ppm: float = 0.0
    scale_asymmetry_ppm: float | tuple[float, ...] = 0.0
    scale_asymmetry_sigma_ppm: float = 0.0
    misalignment_rad: tuple[tuple[float, ...], ...] | None = None
    misalignment_sigma_urad: float = 0.0

    def __post_init__(self) -> None:
        check_bias_terms(self, "ug")
        v.nonneg_finite("noise_ug_rt_hz", self.noise_ug_rt_hz)
        check_axis_errors(self)

    def to_si(self) -> ErrorSpecSI:
        """The same terms in m/s² and m/s/√s."""
        return ErrorSpecSI(white_density=self.noise_ug_rt_hz * UG_RT_HZ, **bias_terms_si(self, "ug", UG_G0),
                           **axis_errors_si(self))


class AccelerometerModel(InertialErrorCore):
    """n-axis accelerometer: ``step_rate(f)`` -> m/s², ``step_increment(f_avg)`` -> m/s.

    Args:
        params: the error parameters.
        n_axes: 3 for a triad, 2 for a level pair.
        rng: the run's seeded numpy Generator (this model's own stream).
        dt: default step [s].

    Input: true specific force along the sensing axes, (n,) m/s², averaged over the step.
    ``true_bias`` (n,) m/s² is the truth to publish.
    """

    def __init__(self, params: AccelerometerParams, n_axes: int, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, AccelerometerParams)
        self.params = params
        super().__init__(params.to_si(), n_axes, rng, dt)

    step = InertialErrorCore.step_rate


#: Paper 3 accelerometers: "accuracy 100 µg" read as a run-to-run bias with σ = 100 µg
#: per axis; white noise 50 µg/√Hz is our choice (quartz-flexure class, paper gives none).
PAPER3_ACCELEROMETER = AccelerometerParams(bias_sigma_ug=100.0, noise_ug_rt_hz=50.0)
