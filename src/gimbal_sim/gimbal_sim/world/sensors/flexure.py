"""Ship angular flexure truth between LGU1 and LGU2 (paper 5 §5.1, docs/spec.md §3.5).

The flexure vector θ = (roll, pitch, yaw) [rad] is the small rotation taking the LGU1 body
frame b1 to the LGU2 body frame b2: ``C_b1b2 ≈ I + [θ×]`` (paper 5 eq. 4), i.e.
``C_b2b1 ≈ I - [θ×]``. It is the sum of

* quasi-static, per axis, closed form in t (t measured from t0):
  ``Φ(t) = Φ0 + r t + A sin(2π t/T + φ_s) + A_h sin(2π t/T_h + φ_h) - A sin φ_s - A_h sin φ_h``
  (the constant terms make Φ(0) = Φ0 whatever the phases); paper 5: Φ0 = 0.1°,
  r = 0.2 °/h, A = 90″, T = 1 h, helm A_h = 0.1°, T_h = 200 s;
* dynamic: a second-order Gauss-Markov process per axis (:class:`SecondOrderGaussMarkov`,
  exact discretisation) with RMS 20″, 60″, 40″ (roll, pitch, yaw). Paper 5 says only
  "second-order Markov" (eq. 12); the default is that textbook process, critically damped
  (λ = 0): R(τ) = σ² e^{−β|τ|}(1 + β|τ|), whose 1/e correlation time is 2.146/β. Paper 5
  gives no bandwidth; wave-driven flexure decorrelates over about a wave period, so the
  default correlation time is 10 s (β = 0.2146 1/s), the ship's roll period. β and a damped
  frequency λ > 0 (a band peaked at λ, e.g. sea waves at 0.5 rad/s) are settable per axis.
  How the band moves the estimator's accuracy is measured in docs/results/paper5.md (the
  dynamic-flexure band). With ``dynamic_model="hull"`` the dynamic part is instead the hull
  girder's bending and torsion under a sea (:mod:`.hull_flexure`: sea spectrum, encounter
  frequency, Froude–Krylov loads, first structural modes), a model the filter does not contain;
  the ``dynamic_rms/beta/freq`` fields are then unused.

The quasi-static part reads, on a ship: Φ0 and the linear rate the loading (stores, fuel) and
the slow heating, the 1 h sinusoid the temperature (sunshine), the helm sinusoid the turn.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import ARCSEC, DEG, DEG_H
from .hull_flexure import HullFlexure, HullParams
from .markov import SecondOrderGaussMarkov

_AXES = 3
#: The dynamic-flexure truth models: the filter's own band, or the hull under a sea.
DYNAMIC_MODELS = ("band", "hull")


@dataclass(frozen=True)
class FlexureParams:
    """Flexure truth parameters; each field a scalar (all axes) or a (roll, pitch, yaw) triple.

    Attributes:
        initial_deg: quasi-static flexure at t0 [°].
        linear_rate_deg_h: linear drift [°/h].
        slow_amplitude_arcsec, slow_period_s, slow_phase_rad: thermal sinusoid.
        helm_amplitude_deg, helm_period_s, helm_phase_rad: helm-induced sinusoid.
        dynamic_rms_arcsec: RMS of the dynamic (second-order Markov) flexure [″].
        dynamic_beta_per_s: its decay rate β [1/s] (> 0).
        dynamic_freq_rad_s: its damped angular frequency λ [rad/s] (>= 0).
        dynamic_model: "band" (the second-order Markov above) or "hull" (:mod:`.hull_flexure`).
        hull: the hull, sea and route of the "hull" model.
    """

    initial_deg: float | tuple[float, ...] = 0.1
    linear_rate_deg_h: float | tuple[float, ...] = 0.2
    slow_amplitude_arcsec: float | tuple[float, ...] = 90.0
    slow_period_s: float | tuple[float, ...] = 3600.0
    slow_phase_rad: float | tuple[float, ...] = 0.0
    helm_amplitude_deg: float | tuple[float, ...] = 0.1
    helm_period_s: float | tuple[float, ...] = 200.0
    helm_phase_rad: float | tuple[float, ...] = 0.0
    dynamic_rms_arcsec: float | tuple[float, ...] = (20.0, 60.0, 40.0)
    dynamic_beta_per_s: float | tuple[float, ...] = 0.2146
    dynamic_freq_rad_s: float | tuple[float, ...] = 0.0
    dynamic_model: str = "band"
    hull: HullParams = HullParams()

    def __post_init__(self) -> None:
        if self.dynamic_model not in DYNAMIC_MODELS:
            raise ValueError(f"dynamic_model must be one of {DYNAMIC_MODELS}, got {self.dynamic_model!r}")
        v.of_type("hull", self.hull, HullParams)
        for name in self.__dataclass_fields__:
            if name in ("dynamic_model", "hull"):
                continue
            vals = v.per_axis(name, getattr(self, name), _AXES)
            object.__setattr__(self, name, vals)
        for name in ("slow_period_s", "helm_period_s", "dynamic_beta_per_s"):
            for x in getattr(self, name):
                v.positive(name, x)
        for name in ("slow_amplitude_arcsec", "helm_amplitude_deg", "dynamic_rms_arcsec", "dynamic_freq_rad_s"):
            for x in getattr(self, name):
                v.nonneg(name, x)


class ShipFlexureTruth:
    """Flexure angle θ(t) and rate θ̇(t) between LGU1 and LGU2 (module docstring).

    Args:
        params: flexure parameters.
        rng: the run's seeded Generator (dynamic part).
        dt: default step [s].
    """

    def __init__(self, params: FlexureParams, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, FlexureParams)
        self.params = params
        p = params
        self._phi0 = [x * DEG for x in p.initial_deg]  # type: ignore[union-attr]
        self._rate = [x * DEG_H for x in p.linear_rate_deg_h]  # type: ignore[union-attr]
        # (amplitude [rad], angular frequency [rad/s], phase [rad]) of the two sinusoids.
        slow = zip(p.slow_amplitude_arcsec, p.slow_period_s, p.slow_phase_rad)  # type: ignore[arg-type]
        helm = zip(p.helm_amplitude_deg, p.helm_period_s, p.helm_phase_rad)  # type: ignore[arg-type]
        self._sines = [
            [(a * ARCSEC, 2.0 * math.pi / T, ph) for a, T, ph in slow],
            [(a * DEG, 2.0 * math.pi / T, ph) for a, T, ph in helm],
        ]
        self.dynamic: SecondOrderGaussMarkov | HullFlexure
        if p.dynamic_model == "hull":
            self.dynamic = HullFlexure(p.hull, rng, dt)
        else:
            self.dynamic = SecondOrderGaussMarkov(
                [x * ARCSEC for x in p.dynamic_rms_arcsec],  # type: ignore[union-attr]
                p.dynamic_beta_per_s,  # type: ignore[arg-type]
                p.dynamic_freq_rad_s,  # type: ignore[arg-type]
                rng,
                dt,
            )
        self.dt = dt
        #: Time since t0 [s].
        self.t = 0.0

    def quasi_static_angle(self, t: float) -> list[float]:
        """Quasi-static flexure Φ(t) [rad], (3,), closed form."""
        out = []
        for i in range(_AXES):
            x = self._phi0[i] + self._rate[i] * t
            for sine in self._sines:
                a, w, ph = sine[i]
                x += a * (math.sin(w * t + ph) - math.sin(ph))
            out.append(x)
        return out

    def quasi_static_rate(self, t: float) -> list[float]:
        """Φ̇(t) [rad/s], (3,), closed form."""
        out = []
        for i in range(_AXES):
            x = self._rate[i]
            for sine in self._sines:
                a, w, ph = sine[i]
                x += a * w * math.cos(w * t + ph)
            out.append(x)
        return out

    def step(self, dt: float | None = None) -> None:
        """Advance time and the dynamic flexure by ``dt`` [s] (default: the constructor's)."""
        self.dynamic.step(dt)
        self.t += self.dt if dt is None else dt

    @property
    def angle(self) -> list[float]:
        """Total flexure θ = Φ(t) + dynamic [rad], (3,)."""
        qs = self.quasi_static_angle(self.t)
        dyn = self.dynamic.value
        return [qs[i] + dyn[i] for i in range(_AXES)]

    @property
    def rate(self) -> list[float]:
        """Total flexure rate θ̇ [rad/s], (3,)."""
        qs = self.quasi_static_rate(self.t)
        dyn = self.dynamic.rate
        return [qs[i] + dyn[i] for i in range(_AXES)]
