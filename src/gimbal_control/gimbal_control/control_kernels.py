"""Compiled per-sample kernels of the control laws (numba ``njit``): plain functions over
floats and float64 arrays. :class:`.pid.Pid` holds a channel's state vector and calls
:func:`pid_step`; :class:`.platform_servo.PlatformServo` keeps its four channels' states as
the rows of one (4, :data:`N_STATE`) array and steps them in one call of :func:`pid_step4`.

PID (the maths is :mod:`.pid`'s docstring), error e, optional measured rate ė::

    D_k = a D_{k−1} + (1 − a) k_d ė_k                 (rate given)
    D_k = a D_{k−1} + (k_d/τ_d)(e_k − e_{k−1})        (τ_d > 0; first sample: e_{k−1} = 0)
    D_k = k_d (e_k − e_{k−1}) / Δt                    (τ_d = 0; none on the first sample)
    I_k = clip(I_{k−1} + k_i e_{k−1} Δt)              (held while the output is clipped and
                                                        the increment pushes further into it)
    u_k = clip(k_p e_k + I_k + D_k),   a = exp(−Δt/τ_d) (0 for τ_d = 0)

State vector (``S_*``): I, D, e_{k−1}, first-sample flag, u, saturated flag, the Δt the
cached a belongs to, a. Gains vector (``G_*``): k_p, k_i, k_d, τ_d, output limit,
integrator limit.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

S_INTEGRAL, S_D, S_E_PREV, S_FIRST, S_OUTPUT, S_SATURATED, S_DT, S_A = range(8)
N_STATE = 8
G_KP, G_KI, G_KD, G_TAU, G_LIM, G_ILIM = range(6)
N_GAINS = 6


@njit(cache=True)
def pid_step(s: np.ndarray, g: np.ndarray, error: float, dt: float, error_rate: float, has_rate: bool) -> float:
    """One PID sample (module docstring); updates the state ``s`` in place, returns u."""
    kd, tau = g[G_KD], g[G_TAU]
    first = s[S_FIRST] != 0.0
    if kd != 0.0:
        if dt != s[S_DT]:
            s[S_DT] = dt
            s[S_A] = math.exp(-dt / tau) if tau > 0.0 else 0.0
        a = s[S_A]
        if has_rate:
            s[S_D] = a * s[S_D] + (1.0 - a) * kd * error_rate
        elif not first:
            if tau > 0.0:
                s[S_D] = a * s[S_D] + kd / tau * (error - s[S_E_PREV])
            else:
                s[S_D] = kd * (error - s[S_E_PREV]) / dt
        elif tau > 0.0:
            s[S_D] = kd / tau * error
    if not first and g[G_KI] != 0.0:
        inc = g[G_KI] * s[S_E_PREV] * dt
        if not (s[S_SATURATED] != 0.0 and (inc > 0.0) == (s[S_OUTPUT] > 0.0)):
            lim = g[G_ILIM]
            s[S_INTEGRAL] = max(-lim, min(lim, s[S_INTEGRAL] + inc))
    s[S_FIRST] = 0.0
    s[S_E_PREV] = error
    u = g[G_KP] * error + s[S_INTEGRAL] + s[S_D]
    lim = g[G_LIM]
    if u > lim:
        u = lim
        s[S_SATURATED] = 1.0
    elif u < -lim:
        u = -lim
        s[S_SATURATED] = 1.0
    else:
        s[S_SATURATED] = 0.0
    s[S_OUTPUT] = u
    return u


@njit(cache=True)
def pid_step4(s: np.ndarray, g: np.ndarray, e0: float, e1: float, e2: float, e3: float,
              r0: float, r1: float, r2: float, dt: float) -> tuple:
    """Four channels (rows of ``s``, ``g``) at one sample: the first three with their
    measured error rates r0..r2, the fourth differencing its error (the platform servo's
    azimuth, inner roll, pitch and outer roll loops)."""
    return (pid_step(s[0], g[0], e0, dt, r0, True), pid_step(s[1], g[1], e1, dt, r1, True),
            pid_step(s[2], g[2], e2, dt, r2, True), pid_step(s[3], g[3], e3, dt, 0.0, False))
