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

import numpy as np

from . import control_kernels as ck


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
    """One discrete PID channel (module docstring). Call :meth:`step` once per sample.

    The state is the vector ``state`` (:mod:`.control_kernels`' ``S_*``; a row of a caller's
    array when one is given, so several channels can step in one kernel call) and the
    arithmetic the compiled :func:`.control_kernels.pid_step`."""

    def __init__(self, params: PidParams, state: np.ndarray | None = None) -> None:
        if not isinstance(params, PidParams):
            raise ValueError("params must be a PidParams")
        self.params = params
        self.gains = np.array([params.kp, params.ki, params.kd, params.derivative_tau_s, params.output_limit,
                               params.integrator_limit], dtype=float)
        self.state = np.zeros(ck.N_STATE) if state is None else state
        self.state[ck.S_DT] = -1.0
        self.reset()

    @property
    def integral(self) -> float:
        """The integrator's output contribution I."""
        return float(self.state[ck.S_INTEGRAL])

    @property
    def output(self) -> float:
        """The last output u."""
        return float(self.state[ck.S_OUTPUT])

    @property
    def saturated(self) -> bool:
        """Whether the last output was clipped."""
        return bool(self.state[ck.S_SATURATED])

    def reset(self, integral: float = 0.0) -> None:
        """Clear the state; ``integral`` presets the integrator output."""
        s = self.state
        s[ck.S_INTEGRAL] = float(integral)
        s[ck.S_D] = s[ck.S_E_PREV] = s[ck.S_OUTPUT] = s[ck.S_SATURATED] = 0.0
        s[ck.S_FIRST] = 1.0

    def forget_previous(self) -> None:
        """Drop the previous sample (after a data gap): the next step neither differences
        nor integrates across the gap; the integrator value is kept."""
        self.state[ck.S_FIRST] = 1.0
        self.state[ck.S_D] = 0.0

    def preset_integral(self, value: float) -> None:
        """Set the integrator's output contribution to ``value`` (clipped to its limit)."""
        lim = self.params.integrator_limit
        self.state[ck.S_INTEGRAL] = max(-lim, min(lim, float(value)))

    def step(self, error: float, dt: float, error_rate: float | None = None) -> float:
        """Output for the error ``error`` at this sample; ``dt`` [s] is the time since the
        previous sample (> 0). ``error_rate`` [error/s], when given, replaces the differenced
        error in the derivative term."""
        return ck.pid_step(self.state, self.gains, float(error), float(dt),
                           0.0 if error_rate is None else float(error_rate), error_rate is not None)
