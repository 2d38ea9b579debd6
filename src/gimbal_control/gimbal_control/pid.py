"""Discrete PID with a filtered derivative, anti-windup and integrator preset (papers 2, 3).

Continuous law, error e = reference − measurement::

    u(s) = (k_p + k_i / s + k_d s / (τ_d s + 1)) e(s)

Discretisation: step-invariant (zero-order-hold equivalent) per term, so the response to a
step in e is exact at the sample instants (the tests check it against the closed form
u(t) = k_p + k_i t + (k_d/τ_d) e^(−t/τ_d)):

* integrator, forward rectangle: I_k = I_{k−1} + k_i e_{k−1} Δt, i.e. the output at t_k
  uses the error up to t_{k−1} (the ZOH equivalent of k_i/s has this one-sample lag);
* derivative, D_k = a D_{k−1} + (k_d/τ_d)(e_k − e_{k−1}),  a = exp(−Δt/τ_d) (ZOH
  equivalent of k_d s/(τ_d s + 1)); τ_d = 0 gives the unfiltered difference k_d Δe/Δt.
  When the error rate is measured (a gyro sees the rate error of an angle loop directly),
  :meth:`Pid.step` takes it as ``error_rate`` and low-passes it by the same first-order
  filter instead of differencing, D_k = a D_{k−1} + (1 − a) k_d ė_k.

Anti-windup: conditional integration. When the output is clipped at ``output_limit`` and
the new error would push it further into the limit, the integrator holds. The integrator
state is also clipped at ``integrator_limit``. :meth:`Pid.preset_integral` sets the
integrator to a given output (paper 3 presets it to the friction torque at a reversal).

Units: whatever the loop uses (e.g. error in rad/s, output in N·m or V); gains accordingly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


def _check(name: str, value: float, *, allow_zero: bool = True, allow_inf: bool = False) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise ValueError(f"{name} must be a number, got {value!r}")
    if math.isinf(value) and not allow_inf:
        raise ValueError(f"{name} must be finite, got {value}")
    if value < 0.0 or (value == 0.0 and not allow_zero):
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {value}")


@dataclass(frozen=True)
class PidParams:
    """PID gains and limits (module docstring). All fields >= 0.

    Attributes:
        kp: proportional gain [output/error].
        ki: integral gain [output/(error·s)].
        kd: derivative gain [output·s/error].
        derivative_tau_s: derivative low-pass time constant τ_d [s] (0 = none).
        output_limit: symmetric output clip ±limit (inf = none).
        integrator_limit: symmetric clip of the integrator's output contribution (inf = none).
    """

    kp: float = 0.0
    ki: float = 0.0
    kd: float = 0.0
    derivative_tau_s: float = 0.0
    output_limit: float = math.inf
    integrator_limit: float = math.inf

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd", "derivative_tau_s"):
            _check(name, getattr(self, name))
        for name in ("output_limit", "integrator_limit"):
            _check(name, getattr(self, name), allow_zero=False, allow_inf=True)
        if self.kp == 0.0 and self.ki == 0.0 and self.kd == 0.0:
            raise ValueError("kp, ki and kd are all 0: the controller would do nothing")


def pole_placement_gains(inertia_kg_m2: float, bandwidth_hz: float, gain_per_torque: float = 1.0,
                         output_limit: float = math.inf, derivative_tau_s: float = 0.0) -> PidParams:
    """PID gains on an *angle* error for a rigid inertia, by pole placement.

    Loop: J θ̈ = g u, u = k_p e + k_i ∫e + k_d ė with e the angle error and ė its rate
    (measured by a gyro), so the closed loop is J s³ + g (k_d s² + k_p s + k_i) = 0.
    Placing a triple real pole at ω = 2π ``bandwidth_hz`` gives (s + ω)³:

        k_d = 3 ω J / g,   k_p = 3 ω² J / g,   k_i = ω³ J / g.

    ``gain_per_torque`` g converts the controller output to torque (1 for an output in
    N·m; k_t/R_a [N·m/V] for a voltage-driven DC motor whose back-EMF is negligible).
    """
    _check("inertia_kg_m2", inertia_kg_m2, allow_zero=False)
    _check("bandwidth_hz", bandwidth_hz, allow_zero=False)
    _check("gain_per_torque", gain_per_torque, allow_zero=False)
    w = 2.0 * math.pi * bandwidth_hz
    j = inertia_kg_m2 / gain_per_torque
    return PidParams(kp=3.0 * w * w * j, ki=w ** 3 * j, kd=3.0 * w * j,
                     derivative_tau_s=derivative_tau_s, output_limit=output_limit)


class Pid:
    """One discrete PID channel (module docstring). Call :meth:`step` once per sample."""

    def __init__(self, params: PidParams) -> None:
        if not isinstance(params, PidParams):
            raise ValueError("params must be a PidParams")
        self.params = params
        self._kp, self._ki, self._kd = params.kp, params.ki, params.kd
        self._tau = params.derivative_tau_s
        self._lim = params.output_limit
        self._ilim = params.integrator_limit
        self._dt_cached = -1.0
        self._a = 0.0
        self.reset()

    def reset(self, integral: float = 0.0) -> None:
        """Clear the state; ``integral`` presets the integrator output."""
        self.integral = float(integral)
        self._d = 0.0
        self._e_prev = 0.0
        self._first = True
        self.output = 0.0
        self.saturated = False

    def forget_previous(self) -> None:
        """Drop the previous sample (after a data gap): the next step neither differences
        nor integrates across the gap; the integrator value is kept."""
        self._first = True
        self._d = 0.0

    def preset_integral(self, value: float) -> None:
        """Set the integrator's output contribution to ``value`` (clipped to its limit)."""
        lim = self._ilim
        self.integral = max(-lim, min(lim, float(value)))

    def _coeff(self, dt: float) -> float:
        if dt != self._dt_cached:
            self._dt_cached = dt
            self._a = math.exp(-dt / self._tau) if self._tau > 0.0 else 0.0
        return self._a

    def step(self, error: float, dt: float, error_rate: float | None = None) -> float:
        """Output for the error ``error`` at this sample; ``dt`` [s] is the time since the
        previous sample (> 0). ``error_rate`` [error/s], when given, replaces the differenced
        error in the derivative term."""
        kd = self._kd
        if kd != 0.0:
            a = self._coeff(dt)
            if error_rate is not None:
                self._d = a * self._d + (1.0 - a) * kd * error_rate
            elif not self._first:
                if self._tau > 0.0:
                    self._d = a * self._d + kd / self._tau * (error - self._e_prev)
                else:
                    self._d = kd * (error - self._e_prev) / dt
            elif self._tau > 0.0:
                # first sample: the error steps from 0 to its value
                self._d = kd / self._tau * error
        if not self._first and self._ki != 0.0:
            self._integrate(self._e_prev, dt)
        self._first = False
        self._e_prev = error
        u = self._kp * error + self.integral + self._d
        lim = self._lim
        if u > lim:
            u, self.saturated = lim, True
        elif u < -lim:
            u, self.saturated = -lim, True
        else:
            self.saturated = False
        self.output = u
        return u

    def _integrate(self, e: float, dt: float) -> None:
        inc = self._ki * e * dt
        # conditional integration: never wind further into a clipped output
        if self.saturated and (inc > 0.0) == (self.output > 0.0):
            return
        lim = self._ilim
        self.integral = max(-lim, min(lim, self.integral + inc))
