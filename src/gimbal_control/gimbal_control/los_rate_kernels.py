"""Compiled per-sample kernel of paper 1's LOS rate controller (numba ``njit``):
:class:`.los_rate_controller.LosRateController` holds the state vector (``S_*``) and the
parameter vector (``G_*``, :func:`controller_params`) and calls :func:`los_rate_step` once a
sample; the engine's compiled sighting loop steps copies of them (:func:`controller_arrays`).

One sample at stamp t (the class's docstring has the derivation), c, s = cos, sin θm
(|c| floored), w the turret's inertial rate in the outer gimbal frame::

    ψ̇_md = (r_md − s w₁)/c − w₃,  θ̇_md = q_md − w₂
    e = (ψ̇_md − ((r_m − b_r) − s w₁)/c + w₃,  θ̇_md − (q_m − b_q) + w₂)
    I ← I + ½Δt (e + e_prev)   (not at the first sample; clamped, or conditional, per anti_windup)
    τ = τ_trim + B′⁻¹ (k_p e + k_i I − A′x),  clipped to the torque limits

A non-finite input is rejected (the last command returned, counted). Samples come checked
and in stamp order: duplicates, samples out of order and clock jumps are the node's input
policy's (:mod:`gimbal_kinematics.timing.control_policy`, which calls the controller's ``reset``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# state: integrators, last rate error, last stamp (NaN: none), command, bias (q, r) subtracted,
# outer-loop rate command, counters, last joint-rate command and unsaturated command
S_IA, S_IE, S_EA_PREV, S_EE_PREV, S_LAST_T, S_TAU_A, S_TAU_E, S_BIAS_Q, S_BIAS_R, S_CMD_Q, S_CMD_R, \
    S_REJECTED_INPUTS, S_SINGULAR, S_SATURATED, S_RESETS, S_JR_A, S_JR_E, S_UNSAT_A, S_UNSAT_E = range(19)
N_STATE = 19
# parameters (A′ rows at G_A0, G_A1, four each)
G_KP, G_KI, G_B00, G_B01, G_B10, G_B11, G_TRIM_A, G_TRIM_E, G_LIM_A, G_LIM_E, G_IMAX_A, G_IMAX_E, G_AW_MODE, \
    G_FEEDBACK, G_MIN_COS, G_DT_NOMINAL, G_DT_MAX, G_A0, G_A1 = (*range(17), 17, 21)
N_PARAMS = 25


def initial_state() -> np.ndarray:
    """The state of a controller that has stepped no sample."""
    s = np.zeros(N_STATE)
    s[S_LAST_T] = math.nan
    return s


def controller_params(core) -> np.ndarray:
    """The parameter vector of a :class:`.los_rate_controller.LosRateController`."""
    p = core.params
    g = np.zeros(N_PARAMS)
    g[G_KP], g[G_KI] = core.kp, core.ki
    g[G_B00], g[G_B01], g[G_B10], g[G_B11] = core._b00, core._b01, core._b10, core._b11
    g[G_TRIM_A], g[G_TRIM_E] = core._trim
    g[G_LIM_A], g[G_LIM_E] = core.torque_limits
    g[G_IMAX_A], g[G_IMAX_E] = core._i_max
    g[G_AW_MODE], g[G_FEEDBACK], g[G_MIN_COS] = core._aw_mode, p.feedback, p.min_cos_elevation
    g[G_DT_NOMINAL], g[G_DT_MAX] = core.dt_nominal, core._dt_max
    g[G_A0:G_A0 + 4], g[G_A1:G_A1 + 4] = core._a
    return g


def controller_arrays(core) -> tuple[np.ndarray, np.ndarray]:
    """(state, parameters) of a :class:`.los_rate_controller.LosRateController` as it stands,
    copies for a compiled loop to step."""
    return core._s.copy(), core._g.copy()


@njit(cache=True)
def _integrate(s: np.ndarray, g: np.ndarray, e_a: float, e_e: float, dt: float, first: bool) -> tuple:
    """(I_a, I_e) after the sample's trapezoid (none at the first sample), clamped in mode 1."""
    i_a, i_e = s[S_IA], s[S_IE]
    if not first:
        h = 0.5 * dt
        i_a = i_a + h * (e_a + s[S_EA_PREV])
        i_e = i_e + h * (e_e + s[S_EE_PREV])
    if g[G_AW_MODE] == 1.0:
        ia_max, ie_max = g[G_IMAX_A], g[G_IMAX_E]
        if i_a > ia_max or i_a < -ia_max:
            i_a = ia_max if i_a > 0.0 else -ia_max
        if i_e > ie_max or i_e < -ie_max:
            i_e = ie_max if i_e > 0.0 else -ie_max
    return i_a, i_e


@njit(cache=True)
def los_rate_step(s: np.ndarray, g: np.ndarray, t: float, q_g: float, r_g: float, psi_t: float, psi_m: float,
                  th: float, psi_t_d: float, psi_m_d: float, th_d: float, wp: float, wq: float, wr: float,
                  q_md: float, r_md: float) -> tuple:
    """The saturated torque command (τ_a, τ_e) [N·m] of one sample (module docstring);
    updates the state ``s``."""
    total = q_g + r_g + psi_t + psi_m + th + psi_t_d + psi_m_d + th_d + wp + wq + wr + q_md + r_md + t
    if total - total != 0.0:
        s[S_REJECTED_INPUTS] += 1.0
        return s[S_TAU_A], s[S_TAU_E]
    last = s[S_LAST_T]
    first = math.isnan(last)
    dt = g[G_DT_NOMINAL] if first else min(t - last, g[G_DT_MAX])
    s[S_LAST_T] = t
    if g[G_FEEDBACK] != 0.0:
        q_g -= s[S_BIAS_Q]
        r_g -= s[S_BIAS_R]
    c, sn = math.cos(th), math.sin(th)
    mc = g[G_MIN_COS]
    if -mc < c < mc:
        s[S_SINGULAR] += 1.0
        c = mc if c >= 0.0 else -mc
    ct, st = math.cos(psi_t), math.sin(psi_t)
    cm, sm = math.cos(psi_m), math.sin(psi_m)
    u1 = ct * wp + st * wq
    u2 = -st * wp + ct * wq
    w1 = cm * u1 + sm * u2
    w2 = -sm * u1 + cm * u2
    w3 = wr + psi_t_d
    psi_md = (r_md - sn * w1) / c - w3
    th_md = q_md - w2
    s[S_JR_A], s[S_JR_E] = psi_md, th_md
    e_a = psi_md - ((r_g - sn * w1) / c - w3)
    e_e = th_md - (q_g - w2)
    i_a_old, i_e_old = s[S_IA], s[S_IE]
    i_a, i_e = _integrate(s, g, e_a, e_e, dt, first)
    s[S_EA_PREV], s[S_EE_PREV] = e_a, e_e
    lim_a, lim_e = g[G_LIM_A], g[G_LIM_E]
    kp, ki = g[G_KP], g[G_KI]
    a0, a1 = g[G_A0:G_A0 + 4], g[G_A1:G_A1 + 4]
    ra = kp * e_a + ki * i_a - (a0[0] * psi_m + a0[1] * th + a0[2] * psi_m_d + a0[3] * th_d)
    re = kp * e_e + ki * i_e - (a1[0] * psi_m + a1[1] * th + a1[2] * psi_m_d + a1[3] * th_d)
    b00, b01, b10, b11 = g[G_B00], g[G_B01], g[G_B10], g[G_B11]
    tau_a = g[G_TRIM_A] + b00 * ra + b01 * re
    tau_e = g[G_TRIM_E] + b10 * ra + b11 * re
    sat_a = tau_a > lim_a or tau_a < -lim_a
    sat_e = tau_e > lim_e or tau_e < -lim_e
    if g[G_AW_MODE] == 2.0 and (sat_a or sat_e):
        undo_a = sat_a and e_a * tau_a > 0.0
        undo_e = sat_e and e_e * tau_e > 0.0
        if undo_a or undo_e:
            da = -(i_a - i_a_old) * ki if undo_a else 0.0
            de = -(i_e - i_e_old) * ki if undo_e else 0.0
            if undo_a:
                i_a = i_a_old
            if undo_e:
                i_e = i_e_old
            tau_a += b00 * da + b01 * de
            tau_e += b10 * da + b11 * de
            sat_a = tau_a > lim_a or tau_a < -lim_a
            sat_e = tau_e > lim_e or tau_e < -lim_e
    s[S_IA], s[S_IE] = i_a, i_e
    s[S_UNSAT_A], s[S_UNSAT_E] = tau_a, tau_e
    if sat_a or sat_e:
        s[S_SATURATED] += 1.0
        tau_a = lim_a if tau_a > lim_a else -lim_a if tau_a < -lim_a else tau_a
        tau_e = lim_e if tau_e > lim_e else -lim_e if tau_e < -lim_e else tau_e
    s[S_TAU_A], s[S_TAU_E] = tau_a, tau_e
    return tau_a, tau_e
