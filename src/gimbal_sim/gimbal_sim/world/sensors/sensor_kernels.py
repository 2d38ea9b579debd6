"""Compiled per-sample kernels of the sensor error models (numba ``njit``): plain functions
over float64 arrays, for the engine's compiled loops. Each is the maths of its model class,
operation for operation, so a kernel and the class give the same bits from the same normals
(``test_sensor_kernels``); the state lives in arrays made from a constructed model
(:func:`inertial_arrays`, :func:`encoder_arrays`), whose init draws are therefore the model's own.

Inertial sensor (:mod:`.inertial_core`), per axis i, z the step's normals (Gauss-Markov
block, random-walk block, white block, each present only when its term is)::

    b_gm ← φ b_gm + d_gm z,   b_rrw ← b_rrw + d_rrw z
    y = k_i u + b_fix + b_gm + b_rrw + σ_w z,   clamped to ±sat
    quantised: v = y Δt + r,  o = δ ⌊v/δ + ½⌋,  r ← v − o,  y = o/Δt

Encoder (:mod:`.encoder`): c = ⌊θ/δ + ½⌋ (θ itself unquantised), angle c δ + σ z, rate
(c − c_ref) δ/T_g once per completed gate of ``gate_steps`` samples.

INS attitude (:mod:`.ins`): first-order Gauss-Markov error e ← φ e + d z per Euler angle,
added to the true angles, yaw wrapped to (−π, π].
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# inertial state rows (n axes each)
S_FIXED, S_GM, S_RRW, S_RESIDUAL = range(4)
# inertial parameters: φ, d_gm, d_rrw, σ_w, saturation, quantum δ, Δt, has_gm, has_rrw, has_white, then k_i per axis
G_PHI, G_GM_DRIVE, G_RRW_DRIVE, G_WHITE_SD, G_SAT, G_QUANTUM, G_DT, G_HAS_GM, G_HAS_RRW, G_HAS_WHITE, G_K = range(11)
# encoder state: c_ref per axis, then (have_ref, k, rate per axis) after them; parameters: δ, σ, gate steps, T_g
E_QUANTUM, E_NOISE, E_GATE_STEPS, E_GATE_S = range(4)


def inertial_arrays(model) -> tuple[np.ndarray, np.ndarray, int]:
    """(state (4, n), parameters, normals per sample) of a constructed
    :class:`.inertial_core.InertialErrorCore` (no misalignment: ``ValueError``)."""
    if model._K is not None:
        raise ValueError("the inertial kernel has no misalignment term")
    n = model.n_axes
    s = np.zeros((4, n))
    s[S_FIXED], s[S_GM], s[S_RRW], s[S_RESIDUAL] = model._fixed, model._gm, model._rrw, model._residual
    g = np.array([model._phi, model._gm_drive, model._rrw_drive, model._white_sd, model._sat, model._quantum,
                  model._dt, model._has_gm, model._has_rrw, model._has_white] + list(model._kdiag), dtype=float)
    return s, g, model._need


@njit(cache=True)
def inertial_rate(s: np.ndarray, g: np.ndarray, u: np.ndarray, z: np.ndarray, out: np.ndarray) -> None:
    """The step-average measurement of true ``u`` (n,) into ``out`` (n,); ``z`` the sample's
    normals; advances the bias states (module docstring)."""
    n = u.shape[0]
    j = 0
    if g[G_HAS_GM] != 0.0:
        phi, d = g[G_PHI], g[G_GM_DRIVE]
        for i in range(n):
            s[S_GM, i] = phi * s[S_GM, i] + d * z[j + i]
        j += n
    if g[G_HAS_RRW] != 0.0:
        d = g[G_RRW_DRIVE]
        for i in range(n):
            s[S_RRW, i] += d * z[j + i]
        j += n
    for i in range(n):
        out[i] = g[G_K + i] * u[i] + s[S_FIXED, i] + s[S_GM, i] + s[S_RRW, i]
    if g[G_HAS_WHITE] != 0.0:
        sd = g[G_WHITE_SD]
        for i in range(n):
            out[i] += sd * z[j + i]
    sat = g[G_SAT]
    if sat != math.inf:
        for i in range(n):
            if out[i] > sat:
                out[i] = sat
            elif out[i] < -sat:
                out[i] = -sat
    q, dt = g[G_QUANTUM], g[G_DT]
    if q > 0.0:
        for i in range(n):
            v = out[i] * dt + s[S_RESIDUAL, i]
            o = q * math.floor(v / q + 0.5)
            s[S_RESIDUAL, i] = v - o
            out[i] = o / dt


def encoder_arrays(model) -> tuple[np.ndarray, np.ndarray]:
    """(state, parameters) of a constructed :class:`.encoder.EncoderModel` that has not
    sampled yet: state = c_ref (n), have_ref, k, rate (n)."""
    n = model.n_axes
    s = np.zeros(2 * n + 2)
    if model._ref is not None:
        s[:n] = model._ref
        s[n] = 1.0
    s[n + 1] = model._k
    s[n + 2:] = model._vel
    g = np.array([model.quantum_rad, model._noise, model._gate_steps, model.gate_time_s])
    return s, g


@njit(cache=True)
def encoder_step(s: np.ndarray, g: np.ndarray, angles: np.ndarray, z: np.ndarray, pos: np.ndarray,
                 rate: np.ndarray) -> None:
    """Angles and pulse-count rates of true ``angles`` (n,) into ``pos``, ``rate``; ``z``
    the sample's n normals (unused without noise)."""
    n = angles.shape[0]
    d = g[E_QUANTUM]
    counts = np.empty(n)
    for i in range(n):
        counts[i] = math.floor(angles[i] / d + 0.5) if d > 0.0 else angles[i]
        pos[i] = counts[i] * d if d > 0.0 else counts[i]
    if g[E_NOISE] > 0.0:
        for i in range(n):
            pos[i] = pos[i] + g[E_NOISE] * z[i]
    if s[n] == 0.0:
        s[:n] = counts
        s[n] = 1.0
    else:
        s[n + 1] += 1.0
        if s[n + 1] >= g[E_GATE_STEPS]:
            scale = (d if d > 0.0 else 1.0) / g[E_GATE_S]
            for i in range(n):
                s[n + 2 + i] = (counts[i] - s[i]) * scale
            s[:n] = counts
            s[n + 1] = 0.0
    for i in range(n):
        rate[i] = s[n + 2 + i]


@njit(cache=True)
def wrap_pi(a: float) -> float:
    """a in (−π, π] (``ins._wrap_pi``)."""
    w = np.fmod(a + math.pi, 2.0 * math.pi)  # exact, as C fmod
    if w <= 0.0:
        w += 2.0 * math.pi
    return w - math.pi


@njit(cache=True)
def ins_attitude(e: np.ndarray, phi: np.ndarray, drive: np.ndarray, z: np.ndarray, roll: float, pitch: float,
                 yaw: float) -> tuple:
    """The measured Euler angles from the true ones, after one step of the attitude errors ``e``
    (3,) (first-order Gauss-Markov with ``phi``, ``drive``, normals ``z``)."""
    for i in range(3):
        e[i] = phi[i] * e[i] + drive[i] * z[i]
    return roll + e[0], pitch + e[1], wrap_pi(yaw + e[2])
