"""Compiled per-sample kernels of the platform servo (numba ``njit``): plain functions over
floats and float64 arrays. The maths is :mod:`.platform_servo`'s docstring; the compiled
engine (``gimbal_sim.core.compiled_platform``) holds one servo's state in a vector
(``S_*`` indices) and its constants in another (``P_*``), and calls :func:`servo_resolvers`,
:func:`servo_command` and :func:`servo_tick` per sample, as the node's core takes its
messages. Per tick (gyro ω, resolver angles θ, the newest command ω_c^n, stamp t)::

    φz, φ̇z = schedule(t − t₀)                       (rest before the first tick / rotation off)
    ω_c = rot3(φz) ω_c^n + φ̇z e3                    (navigator's while younger than the max age)
    ω_c = rot3(φz) ω_ie^n(L) + φ̇z e3 − ε̂            (internal)
    e = ω − ω_c + φ̇z e3,   δ⁺ = δ + ½Δt (e_prev + e) − Δφz e3 − Δt ω_c × δ
    (Δθ_q, Δθ_p, Δθ_a), (ė_q, ė_p, ė_a), Δθ_r = eq. 1 of δ and e − φ̇z e3 through θ_a, θ_q, θ_p
    V = PID(−Δθ_a, −Δθ_q, −Δθ_p, Δθ_r; rates −ė_a, −ė_q, −ė_p)

with the azimuth integrator preset to the friction voltage of the new direction at each
change of sign of φ̇z. Stamps are the lockstep engine's (rising), or checked and ordered by
the node's input policy (:mod:`gimbal_kinematics.timing.control_policy`): none is judged here.
:class:`.platform_servo.PlatformServo` holds the same vectors and calls the same kernels.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.maths.platform_kernels import servo_signals

from .control_kernels import S_D, S_FIRST, S_INTEGRAL, pid_step, pid_step4

(S_T0, S_T_TICK, S_HAS_ANGLES, S_A0, S_A1, S_A2, S_A3, S_HAS_CMD, S_T_CMD, S_C0, S_C1, S_C2, S_D0, S_D1, S_D2,
 S_HAS_PREV, S_PEX, S_PEY, S_PEZ, S_PPHI, S_DIR, S_V0, S_V1, S_V2, S_V3, S_G0, S_G1, S_G2, S_G3, S_DT_LAST,
 S_PHI, S_PHI_RATE, S_NO_CMD, S_STALE, S_HELD, S_LOCK, S_PRESETS, S_NONFINITE, S_GAPS) = range(39)
N_STATE = 39
(P_ROTATE, P_RATE, P_SWEEP, P_LEG, P_HALF, P_NAVIGATOR, P_MAX_AGE, P_MAX_GAP, P_W0, P_W2, P_DRIFT0, P_DRIFT1,
 P_DRIFT2, P_LOCK_COS, P_PRESET, P_V_POS, P_V_NEG) = range(17)
N_PARAMS = 17
#: what :func:`servo_tick` returns: no output (no resolver angles yet), the last command
#: held (bad input), a new command
TICK_NONE, TICK_HELD, TICK_NEW = -1, 0, 1


def initial_state() -> np.ndarray:
    """A servo before its first sample (no tick, angles or command; Δt 1 ms)."""
    s = np.zeros(N_STATE)
    s[S_T0] = s[S_T_TICK] = math.nan
    s[S_DT_LAST] = 1e-3
    return s


@njit(cache=True)
def schedule_state(t: float, rate: float, sweep: float, leg: float, half: float) -> tuple:
    """(φz, φ̇z) of the bidirectional schedule at ``t`` from its start
    (``gimbal_kinematics.maths.four_gimbal.BidirectionalRotation.state``)."""
    if t < 0.0:
        return 0.0, 0.0
    k = math.floor(t / leg)
    tau = t - k * leg
    if half > 0.0 and tau < half:
        acc = rate / half
        ang, r = 0.5 * acc * tau * tau, acc * tau
    elif half > 0.0 and tau > leg - half:
        rem = leg - tau
        ang, r = sweep - 0.5 * rate / half * rem * rem, rate / half * rem
    else:
        ang, r = rate * half / 2.0 + rate * (tau - half), rate
    if k % 2.0 != 0.0:
        return sweep - ang, -r
    return ang, r


@njit(cache=True)
def servo_resolvers(s: np.ndarray, t: float, a0: float, a1: float, a2: float, a3: float) -> None:
    """Resolver angles (θ_a, θ_q, θ_p, θ_r) [rad] at ``t``; a non-finite one is counted."""
    if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(a2) and math.isfinite(a3)):
        s[S_NONFINITE] += 1.0
        return
    s[S_HAS_ANGLES] = 1.0
    s[S_A0], s[S_A1], s[S_A2], s[S_A3] = a0, a1, a2, a3


@njit(cache=True)
def servo_command(s: np.ndarray, t: float, c0: float, c1: float, c2: float) -> None:
    """The navigator's command rate ω_c^n (N, E, D) [rad/s] at ``t``, held until the next."""
    if not (math.isfinite(c0) and math.isfinite(c1) and math.isfinite(c2)):
        s[S_NONFINITE] += 1.0
        return
    s[S_HAS_CMD] = 1.0
    s[S_T_CMD] = t
    s[S_C0], s[S_C1], s[S_C2] = c0, c1, c2


@njit(cache=True)
def _phi(s: np.ndarray, p: np.ndarray, t: float) -> tuple:
    if math.isnan(s[S_T0]) or p[P_ROTATE] == 0.0:
        return 0.0, 0.0
    return schedule_state(t - s[S_T0], p[P_RATE], p[P_SWEEP], p[P_LEG], p[P_HALF])


@njit(cache=True)
def servo_modulation(s: np.ndarray, p: np.ndarray, t: float) -> tuple:
    """(φz, φ̇z) [rad, rad/s] of the schedule at a tick at ``t`` (the rest, (0, 0), before the
    first tick or with rotation off): a function of time, so known before its tick."""
    return _phi(s, p, t)


@njit(cache=True)
def _command_rate(s: np.ndarray, p: np.ndarray, t: float, phi: float, phi_rate: float) -> tuple:
    """ω_c in s: the navigator's while fresh, else the internal command (counted)."""
    c, sn = math.cos(phi), math.sin(phi)
    if p[P_NAVIGATOR] != 0.0:
        if s[S_HAS_CMD] == 0.0:
            s[S_NO_CMD] += 1.0
        elif t - s[S_T_CMD] > p[P_MAX_AGE]:
            s[S_STALE] += 1.0
        else:
            x, y = c * s[S_C0] + sn * s[S_C1], -sn * s[S_C0] + c * s[S_C1]
            return x, y, s[S_C2] + phi_rate
    w0, w2 = p[P_W0], p[P_W2]
    return (c * w0 + sn * 0.0 - p[P_DRIFT0], -sn * w0 + c * 0.0 - p[P_DRIFT1], w2 + phi_rate - p[P_DRIFT2])


@njit(cache=True)
def servo_held(s: np.ndarray, p: np.ndarray, t: float) -> int:
    """The last command held at ``t`` (bad input): counted, with the schedule's φz, φ̇z."""
    s[S_HELD] += 1.0
    s[S_PHI], s[S_PHI_RATE] = _phi(s, p, t)
    return TICK_HELD


@njit(cache=True)
def _tick_dt(s: np.ndarray, p: np.ndarray, pid_s: np.ndarray, t: float) -> float:
    """The tick's Δt from the last one (0 at the first); a gap longer than the maximum
    restarts the pickoff integration and the PIDs' differences (counted) and gives 0."""
    if math.isnan(s[S_T0]):
        s[S_T0] = t
    dt = 0.0 if math.isnan(s[S_T_TICK]) else t - s[S_T_TICK]
    s[S_T_TICK] = t
    if dt > p[P_MAX_GAP]:
        s[S_GAPS] += 1.0
        s[S_HAS_PREV] = 0.0
        for j in range(4):
            pid_s[j, S_FIRST] = 1.0
            pid_s[j, S_D] = 0.0
        dt = 0.0
    return dt


@njit(cache=True)
def _preset_dt(s: np.ndarray, p: np.ndarray, pid_s: np.ndarray, dt: float, phi_rate: float) -> float:
    """The PIDs' Δt (the last one's when this is 0), with the azimuth integrator preset to
    the friction voltage of the new direction when φ̇z changes sign."""
    if dt > 0.0:
        s[S_DT_LAST] = dt
    else:
        dt = s[S_DT_LAST]
    direction = (phi_rate > 0.0) - (phi_rate < 0.0)
    if direction != 0 and direction != s[S_DIR]:
        if p[P_PRESET] != 0.0:
            pid_s[0, S_INTEGRAL] = p[P_V_POS] if direction > 0 else p[P_V_NEG]
            s[S_PRESETS] += 1.0
        s[S_DIR] = direction
    return dt


@njit(cache=True)
def servo_tick(s: np.ndarray, p: np.ndarray, pid_s: np.ndarray, pid_g: np.ndarray, t: float,
               wx: float, wy: float, wz: float) -> int:
    """One control tick on the gyro sample ω (x, y, z in s) [rad/s] at ``t`` (module
    docstring); the voltages in ``s[S_V0:S_V3+1]``, the signals in ``s[S_G0:S_G3+1]``."""
    if not (math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz)):
        s[S_NONFINITE] += 1.0
        return servo_held(s, p, t)
    if s[S_HAS_ANGLES] == 0.0:
        return TICK_NONE
    dt = _tick_dt(s, p, pid_s, t)
    phi, phi_rate = _phi(s, p, t)
    cx, cy, cz = _command_rate(s, p, t, phi, phi_rate)
    ex, ey, ez0 = wx - cx, wy - cy, wz - (cz - phi_rate)
    if s[S_HAS_PREV] != 0.0 and dt > 0.0:
        h = 0.5 * dt
        d0, d1, d2 = s[S_D0], s[S_D1], s[S_D2]
        s[S_D0] = d0 + h * (s[S_PEX] + ex) - dt * (cy * d2 - cz * d1)
        s[S_D1] = d1 + h * (s[S_PEY] + ey) - dt * (cz * d0 - cx * d2)
        s[S_D2] = d2 + h * (s[S_PEZ] + ez0) - (phi - s[S_PPHI]) - dt * (cx * d1 - cy * d0)
    s[S_HAS_PREV] = 1.0
    s[S_PEX], s[S_PEY], s[S_PEZ], s[S_PPHI] = ex, ey, ez0, phi
    ok, sig, rate_sig, sig_r = servo_signals(s[S_D0], s[S_D1], s[S_D2], ex, ey, ez0 - phi_rate, s[S_A0], s[S_A1],
                                             s[S_A2], p[P_LOCK_COS])
    if not ok:
        s[S_LOCK] += 1.0
        return servo_held(s, p, t)
    dt = _preset_dt(s, p, pid_s, dt, phi_rate)
    sq, sp, sa = sig
    rq, rp, ra = rate_sig
    s[S_V0], s[S_V1], s[S_V2], s[S_V3] = pid_step4(pid_s, pid_g, -sa, -sq, -sp, sig_r, -ra, -rq, -rp, dt)
    s[S_G0], s[S_G1], s[S_G2], s[S_G3] = sa, sq, sp, sig_r
    s[S_PHI], s[S_PHI_RATE] = phi, phi_rate
    return TICK_NEW


@njit(cache=True)
def _clip(v: float, lim: float) -> float:
    return lim if v > lim else -lim if v < -lim else v


@njit(cache=True)
def servo_tick_pickoff(s: np.ndarray, p: np.ndarray, pid_s: np.ndarray, pid_g: np.ndarray, t: float,
                       dx: float, dy: float, dz: float, scale: float, i_max: float) -> tuple:
    """One control tick on the DTG pickoffs: the platform's dip angles δ (x, y, z in s) [rad]
    read from the gyros (``gimbal_kinematics.maths.dtg.platform_deviation``) replace the
    emulated δ, the four PIDs difference their errors (no rate gyro), and the command ω_c
    becomes torquer currents ω_c / ``scale`` [A] (nominal scale factor [rad/s/A], clipped at
    ``i_max``). Returns (result, i_x, i_y, i_z); the currents are zero until a command is made."""
    if not (math.isfinite(dx) and math.isfinite(dy) and math.isfinite(dz)):
        s[S_NONFINITE] += 1.0
        return servo_held(s, p, t), 0.0, 0.0, 0.0
    if s[S_HAS_ANGLES] == 0.0:
        return TICK_NONE, 0.0, 0.0, 0.0
    dt = _tick_dt(s, p, pid_s, t)
    phi, phi_rate = _phi(s, p, t)
    cx, cy, cz = _command_rate(s, p, t, phi, phi_rate)
    s[S_D0], s[S_D1], s[S_D2] = dx, dy, dz
    ok, sig, _, sig_r = servo_signals(dx, dy, dz, 0.0, 0.0, 0.0, s[S_A0], s[S_A1], s[S_A2], p[P_LOCK_COS])
    currents = (_clip(cx / scale, i_max), _clip(cy / scale, i_max), _clip(cz / scale, i_max))
    if not ok:
        s[S_LOCK] += 1.0
        return servo_held(s, p, t), currents[0], currents[1], currents[2]
    dt = _preset_dt(s, p, pid_s, dt, phi_rate)
    sq, sp, sa = sig
    s[S_V0] = pid_step(pid_s[0], pid_g[0], -sa, dt, 0.0, False)
    s[S_V1] = pid_step(pid_s[1], pid_g[1], -sq, dt, 0.0, False)
    s[S_V2] = pid_step(pid_s[2], pid_g[2], -sp, dt, 0.0, False)
    s[S_V3] = pid_step(pid_s[3], pid_g[3], sig_r, dt, 0.0, False)
    s[S_G0], s[S_G1], s[S_G2], s[S_G3] = sa, sq, sp, sig_r
    s[S_PHI], s[S_PHI_RATE] = phi, phi_rate
    return TICK_NEW, currents[0], currents[1], currents[2]
