"""Compiled per-sample kernels of the four-gimbal platform's DC-motor loops (numba ``njit``).

A kernel is a plain function over floats and float64 arrays: no objects, no state of its
own. :class:`.platform_loops.PlatformAxis` holds one axis's parameters and calls the
single-axis kernels; :class:`..vehicle.VehicleCore` (the ``vehicle_dynamics`` node's core and
the engine's plant alike) steps its four axes with :func:`platform_step`, which calls the
same single-axis kernels, so every caller computes the same numbers.

The model (see :mod:`.platform_loops`), per axis, state (θ, ω, i)::

    L di/dt = V − R i − k_e (ω − ω_A)
    J dω/dt = k_t i − T_c tanh((ω − ω_A)/ω_s) − B (ω − ω_A) + T_d
    dθ/dt   = ω

Parameter vector ``p`` (float64, :data:`N_PARAMS`), in the order of the ``P_*`` indices:
J, 1/J, 1/L, R, k_t, k_e, B, T_c, 1/ω_s, V_max. The arithmetic is written in the order of
the former pure-Python step, so compiled and interpreted results differ in the last bits
at most.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.maths.platform_kernels import outer_member_rates

P_J, P_INV_J, P_INV_L, P_R, P_KT, P_KE, P_B, P_TC, P_INV_WS, P_VMAX = range(10)
N_PARAMS = 10


@njit(cache=True)
def saturate(v: float, vmax: float) -> float:
    """V clipped to ±V_max [V]."""
    return vmax if v > vmax else -vmax if v < -vmax else v


@njit(cache=True)
def axis_derivative(w: float, i: float, v: float, wa: float, td: float, p: np.ndarray) -> tuple:
    """ẋ = (ω, ω̇, di/dt) of one axis at rate ``w``, current ``i``, applied voltage ``v``,
    outer-member rate ``wa`` and disturbance torque ``td`` (module docstring)."""
    rel = w - wa
    torque = p[P_KT] * i - p[P_TC] * math.tanh(rel * p[P_INV_WS]) - p[P_B] * rel + td
    return w, torque * p[P_INV_J], (v - p[P_R] * i - p[P_KE] * rel) * p[P_INV_L]


@njit(cache=True)
def _rk4(th: float, w: float, i: float, v: float, wa0: float, wam: float, wa1: float,
         td0: float, tdm: float, td1: float, dt: float, p: np.ndarray) -> tuple:
    h = 0.5 * dt
    a1, b1, c1 = axis_derivative(w, i, v, wa0, td0, p)
    a2, b2, c2 = axis_derivative(w + h * b1, i + h * c1, v, wam, tdm, p)
    a3, b3, c3 = axis_derivative(w + h * b2, i + h * c2, v, wam, tdm, p)
    a4, b4, c4 = axis_derivative(w + dt * b3, i + dt * c3, v, wa1, td1, p)
    k = dt / 6.0
    return (th + k * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            w + k * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
            i + k * (c1 + 2.0 * c2 + 2.0 * c3 + c4))


@njit(cache=True)
def quad(y0: float, ym: float, y1: float, s: float) -> float:
    """The quadratic through (0, y0), (1/2, ym), (1, y1) at ``s``."""
    return y0 * (1.0 - s) * (1.0 - 2.0 * s) + ym * 4.0 * s * (1.0 - s) + y1 * s * (2.0 * s - 1.0)


@njit(cache=True)
def axis_rk4(th: float, w: float, i: float, voltage: float, wa: tuple, td: tuple, dt: float,
             substeps: int, p: np.ndarray) -> tuple:
    """(θ, ω, i) after ``dt`` by ``substeps`` classical RK4 steps with the saturated voltage
    held; ``wa`` and ``td`` are (ω_A, T_d) sampled at (t, t + dt/2, t + dt), interpolated by
    the quadratic through them at each substep's t, t + h/2, t + h (h = dt/substeps)."""
    v = saturate(voltage, p[P_VMAX])
    h = dt / substeps
    for k in range(substeps):
        s0 = k / substeps
        if substeps == 1:
            wa0, wam, wa1 = wa
            td0, tdm, td1 = td
        else:
            sm, s1 = s0 + 0.5 / substeps, s0 + 1.0 / substeps
            wa0, wam, wa1 = quad(wa[0], wa[1], wa[2], s0), quad(wa[0], wa[1], wa[2], sm), quad(wa[0], wa[1], wa[2], s1)
            td0, tdm, td1 = quad(td[0], td[1], td[2], s0), quad(td[0], td[1], td[2], sm), quad(td[0], td[1], td[2], s1)
        th, w, i = _rk4(th, w, i, v, wa0, wam, wa1, td0, tdm, td1, h, p)
    return th, w, i


@njit(cache=True)
def axis_quasi_static(th: float, w0: float, voltage: float, wa: float, td: float, dt: float,
                      p: np.ndarray) -> tuple:
    """(θ, ω, i) after ``dt`` with the armature at its quasi-static current
    i = (V − k_e ω_rel)/R and the rate implicit (backward Euler)::

        J (ω₁ − ω₀)/dt = k_t i(ω₁) − T_f(ω₁ − ω_A) + T_d

    g(ω) = lin ω − rhs + T_c tanh((ω − ω_A)/ω_s) is increasing, its root bracketed by
    tanh ∈ [−1, 1]; safeguarded Newton (bisection when a step leaves the bracket), at most 60
    iterations; θ by the trapezoid."""
    v = saturate(voltage, p[P_VMAX])
    jdt = p[P_J] / dt
    kk = p[P_KT] * p[P_KE] / p[P_R]
    lin = jdt + kk + p[P_B]
    rhs = jdt * w0 + p[P_KT] * v / p[P_R] + (kk + p[P_B]) * wa + td
    tc, inv_ws = p[P_TC], p[P_INV_WS]
    lo, hi = (rhs - tc) / lin, (rhs + tc) / lin
    w = min(max(w0, lo), hi)
    for _ in range(60):
        th_rel = math.tanh((w - wa) * inv_ws)
        g = lin * w - rhs + tc * th_rel
        if g > 0.0:
            hi = w
        else:
            lo = w
        w_new = w - g / (lin + tc * inv_ws * (1.0 - th_rel * th_rel))
        if not lo <= w_new <= hi:
            w_new = 0.5 * (lo + hi)
        if abs(w_new - w) <= 1e-15 + 1e-13 * abs(w):
            w = w_new
            break
        w = w_new
    return th + 0.5 * dt * (w0 + w), w, (v - p[P_KE] * (w - wa)) / p[P_R]


@njit(cache=True)
def platform_step(x: np.ndarray, voltages: np.ndarray, disturbance: np.ndarray, dt: float, substeps: int,
                  quasi_static: bool, params: np.ndarray) -> None:
    """Advance the axes' states ``x`` (n, 3) = (θ, ω, i) per axis in place over ``dt``,
    each under its held voltage ``voltages[j]`` and held disturbance torque
    ``disturbance[j]`` (no outer-member rate): :func:`axis_rk4` with ``substeps``, or
    :func:`axis_quasi_static`. ``params`` (n, :data:`N_PARAMS`)."""
    for j in range(x.shape[0]):
        p = params[j]
        d = disturbance[j]
        if quasi_static:
            th, w, i = axis_quasi_static(x[j, 0], x[j, 1], voltages[j], 0.0, d, dt, p)
        else:
            th, w, i = axis_rk4(x[j, 0], x[j, 1], x[j, 2], voltages[j], (0.0, 0.0, 0.0), (d, d, d), dt, substeps, p)
        x[j, 0], x[j, 1], x[j, 2] = th, w, i


@njit(cache=True)
def base_torques(wx: float, wy: float, wz: float, x: np.ndarray, last: np.ndarray, params: np.ndarray, dt: float,
                 out: np.ndarray) -> None:
    """A moving base's torque −J ω̇_A on each axis (a, q, p, r) [N·m] into ``out``: the outer
    members' inertial rates ω_A about the joint axes
    (:func:`gimbal_kinematics.maths.platform_kernels.outer_member_rates`) of the base rate
    ω_ib^b (wx, wy, wz) and the joint states ``x`` (4, 3), differenced from the last step's,
    ``last`` = (has one, ω_A per axis), which this updates (none yet: no torque). What
    :meth:`..vehicle.VehicleCore._base_torques` computes, in the same order."""
    w = outer_member_rates(wx, wy, wz, x[1, 0], x[2, 0], x[3, 0], x[1, 1], x[2, 1], x[3, 1])
    if last[0] == 0.0:
        last[0] = 1.0
        for j in range(4):
            last[1 + j] = w[j]
    for j in range(4):
        out[j] = -params[j, P_J] * (w[j] - last[1 + j]) / dt
        last[1 + j] = w[j]
