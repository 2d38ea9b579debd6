"""Reusable n-axis gyro error model: parameters at the config edge, presets from the papers.

Terms (docs/spec.md §3.1, paper 1 §3): fixed bias (given and/or drawn per run), first-order
Gauss-Markov bias instability (exact discretisation), angle random walk, rate random walk,
scale-factor error, its asymmetry and the small-angle axis misalignment (each given and/or
drawn per run), quantisation with carried residual and saturation; output as step-average
rate [rad/s] or incremental angle [rad]. The maths is in :mod:`.inertial_core`; this module
converts the unit-suffixed fields to SI once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import DEG, DEG_H, DEG_H_RT_H, DEG_RT_H
from .inertial_core import (ErrorSpecSI, InertialErrorCore, axis_errors_si, bias_terms_si, check_axis_errors,
                            check_bias_terms)


@dataclass(frozen=True)
class GyroParams:
    """Gyro error parameters in engineering units (validated, immutable).

    Per-axis fields take a scalar (every axis) or one value per axis.

    Attributes:
        bias_deg_h: given fixed bias [°/h].
        bias_sigma_deg_h: σ of a run-to-run bias drawn once per run and added [°/h].
        bias_instability_deg_h: stationary RMS of the Gauss-Markov bias instability [°/h].
        bias_instability_tau_s: its correlation time [s] (> 0; inf = random constant).
        arw_deg_rt_h: angle random walk [°/√h].
        rrw_deg_h_rt_h: rate random walk [°/h/√h].
        scale_factor_ppm: given scale-factor error s [ppm].
        scale_factor_sigma_ppm: σ of a run-to-run scale-factor error drawn per axis and added [ppm].
        scale_asymmetry_ppm: given scale-factor asymmetry A = K+ − K− [ppm]: the scale factor is
            1 + s + A/2 for a positive input, 1 + s − A/2 for a negative one (IEEE Std 528).
        scale_asymmetry_sigma_ppm: σ of a run-to-run asymmetry drawn per axis and added [ppm].
        misalignment_rad: (n, n) small-angle cross-coupling, zero diagonal [rad], or None.
        misalignment_sigma_urad: σ of a run-to-run draw added to each off-diagonal element [µrad].
        quantisation_rad: incremental-angle quantum [rad] (0 = none).
        saturation_deg_s: measurement range ±[°/s] (inf = none).
    """

    bias_deg_h: float | tuple[float, ...] = 0.0
    bias_sigma_deg_h: float = 0.0
    bias_instability_deg_h: float = 0.0
    bias_instability_tau_s: float = math.inf
    arw_deg_rt_h: float = 0.0
    rrw_deg_h_rt_h: float = 0.0
    scale_factor_ppm: float | tuple[float, ...] = 0.0
    misalignment_rad: tuple[tuple[float, ...], ...] | None = None
    quantisation_rad: float = 0.0
    saturation_deg_s: float = math.inf
    scale_factor_sigma_ppm: float = 0.0
    scale_asymmetry_ppm: float | tuple[float, ...] = 0.0
    scale_asymmetry_sigma_ppm: float = 0.0
    misalignment_sigma_urad: float = 0.0

    def __post_init__(self) -> None:
        check_bias_terms(self, "deg_h")
        v.nonneg_finite("arw_deg_rt_h", self.arw_deg_rt_h)
        v.nonneg_finite("rrw_deg_h_rt_h", self.rrw_deg_h_rt_h)
        check_axis_errors(self)
        v.nonneg_finite("quantisation_rad", self.quantisation_rad)
        v.positive("saturation_deg_s", self.saturation_deg_s, allow_inf=True)

    def to_si(self) -> ErrorSpecSI:
        """The same terms in rad/s, rad/√s, rad/s/√s, rad (done once per model)."""
        return ErrorSpecSI(
            **bias_terms_si(self, "deg_h", DEG_H),
            white_density=self.arw_deg_rt_h * DEG_RT_H,
            rrw_density=self.rrw_deg_h_rt_h * DEG_H_RT_H,
            quantum=float(self.quantisation_rad),
            saturation=self.saturation_deg_s * DEG,
            **axis_errors_si(self),
        )


class GyroModel(InertialErrorCore):
    """n-axis gyro: ``step_rate(omega)`` -> rad/s, ``step_increment(omega_avg)`` -> rad.

    Args:
        params: the error parameters.
        n_axes: sensing axes (2 for the gimbal gyro's q_m, r_m; 3 for a triad).
        rng: the run's seeded numpy Generator (this model's own stream).
        dt: default step [s].

    Inputs are the true inertial rates along the sensing axes, (n,) rad/s, averaged over
    the step. ``true_bias`` (n,) rad/s is what the simulator publishes as truth.
    """

    def __init__(self, params: GyroParams, n_axes: int, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, GyroParams)
        self.params = params
        super().__init__(params.to_si(), n_axes, rng, dt)


#: Paper 1 gimbal gyro (q_m, r_m): 100 °/h bias (given, so the no-EKF LOS drift of
#: docs/spec.md §3.1, ~3.3° in 120 s, is reproduced every run), ARW 0.15 °/√h, bias instability
#: Gauss-Markov 30 °/h RMS with τ = 100 s.
PAPER1_GIMBAL_GYRO = GyroParams(
    bias_deg_h=100.0, arw_deg_rt_h=0.15, bias_instability_deg_h=30.0, bias_instability_tau_s=100.0
)

#: Paper 1 INS rate errors: 1 °/h fixed bias (the paper gives RMS values, so it is drawn
#: per run with σ = 1 °/h), 1 °/h Gauss-Markov with τ = 60 s, ARW 0.1 °/√h.
PAPER1_INS_GYRO = GyroParams(
    bias_sigma_deg_h=1.0, arw_deg_rt_h=0.1, bias_instability_deg_h=1.0, bias_instability_tau_s=60.0
)

#: Ring-laser-gyro unit noise for paper 5 (the paper gives no figure): ARW 0.001 °/√h,
#: a navigation-grade RLG.
LGU_ARW_DEG_RT_H = 0.001

#: Paper 5 LGU1 / LGU2: fixed biases +0.05 °/h and -0.05 °/h on every axis.
LGU1_GYRO = GyroParams(bias_deg_h=0.05, arw_deg_rt_h=LGU_ARW_DEG_RT_H)
LGU2_GYRO = GyroParams(bias_deg_h=-0.05, arw_deg_rt_h=LGU_ARW_DEG_RT_H)


#: Paper 3 DTG "accuracy 0.03 °/h": run-to-run bias σ = 0.03 °/h per axis; ARW
#: 0.003 °/√h is our choice (the paper gives no noise figure).
PAPER3_GYRO = GyroParams(bias_sigma_deg_h=0.03, arw_deg_rt_h=0.003)
