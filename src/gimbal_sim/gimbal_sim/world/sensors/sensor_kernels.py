"""Compiled per-sample kernels of the encoder and inertial sensor models (numba ``njit``):
plain functions over float64 arrays, the normals drawn beforehand from the model's own
stream in its order (``NormalStream.take_block``). The maths is :mod:`.encoder`'s and
:mod:`.inertial_core`'s docstrings:

    encoder:   c = ⌊θ/δ + ½⌋,  θ̃ = c δ + σ z,  ω̃ = (c − c_ref) δ / T_g every gate (held between)
    inertial:  y = K u + a ∘ |u| + b_fix + b_gm + b_rrw + (N/√Δt) z   (K = I + S + M, a = half the
               scale-factor asymmetry; b_gm, b_rrw advanced first; clamped; the increment y Δt
               quantised with its residual carried)

:class:`.encoder.EncoderModel` and :class:`.inertial_core.InertialErrorCore` hold their state
in the arrays of :func:`encoder_step` and :func:`inertial_step` and call them per sample; the
compiled engine (``gimbal_sim.core.compiled_platform``) calls both kernels
over the models' states (``E_*`` for an encoder set).

INS attitude (:mod:`.ins`): per Euler angle a first-order Gauss-Markov error e ← φ e + d z or a
damped Schuler oscillation (θ, θ̇) ← Φ (θ, θ̇) + L z, added to the true angles, yaw wrapped to
(−π, π] (:func:`ins_attitude`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


E_HAS_REF, E_K = 0, 1  # then the reference counts (n) and the held rates (n)


@njit(cache=True)
def cyclic_error(angles: np.ndarray, n: int, amplitude: float, harmonic: float, phases: np.ndarray,
                 out: np.ndarray) -> None:
    """The angles a converter with a cyclic error reads: ``θ + A sin(h θ + φ_i)`` per axis
    (:class:`.encoder.EncoderParams`' ``cyclic_error_arcsec``), into ``out``."""
    for i in range(n):
        out[i] = angles[i] + amplitude * math.sin(harmonic * angles[i] + phases[i])


@njit(cache=True)
def encoder_step(state: np.ndarray, n: int, angles: np.ndarray, quantum: float, noise: float, gate_steps: int,
                 gate_time: float, z: np.ndarray, out_angles: np.ndarray, out_rates: np.ndarray) -> None:
    """One sample of ``n`` encoders (``EncoderModel.step``): measured angles and rates into
    ``out_angles``, ``out_rates``; ``z`` holds the sample's ``n`` normals when ``noise`` > 0.
    ``state``: has-reference flag, gate step count, reference counts (n), held rates (n)."""
    ref, vel = 2, 2 + n
    for i in range(n):
        if quantum > 0.0:
            c = np.floor(angles[i] / quantum + 0.5)
            out_angles[i] = c * quantum
        else:
            c = angles[i]
            out_angles[i] = c
        if noise > 0.0:
            out_angles[i] = out_angles[i] + noise * z[i]
        out_rates[i] = c  # the counts, until the gate logic below
    if state[E_HAS_REF] == 0.0:
        state[E_HAS_REF] = 1.0
        for i in range(n):
            state[ref + i] = out_rates[i]
    else:
        state[E_K] += 1.0
        if state[E_K] >= gate_steps:
            scale = (quantum if quantum > 0.0 else 1.0) / gate_time
            for i in range(n):
                c = out_rates[i]
                state[vel + i] = (c - state[ref + i]) * scale
                state[ref + i] = c
            state[E_K] = 0.0
    for i in range(n):
        out_rates[i] = state[vel + i]


#: an inertial model's constants (``I_*``): Gauss-Markov φ and drive, random-walk drive,
#: white-noise σ of the step average, saturation, increment quantum, step Δt, which bias
#: states evolve, whether the full matrix K (misalignment) applies, whether the scale factor
#: is asymmetric
(I_PHI, I_GM_DRIVE, I_RRW_DRIVE, I_WHITE_SD, I_SATURATION, I_QUANTUM, I_DT, I_HAS_GM, I_HAS_RRW, I_HAS_K,
 I_HAS_ASYM) = range(11)
N_INERTIAL = 11
#: rows of an inertial model's state array: scale factors 1 + s, fixed bias, Gauss-Markov
#: and random-walk bias states, the quantiser's carried residual, half the scale-factor
#: asymmetry a = A/2 (the scale factor is 1 + s + a for a positive input, 1 + s − a for a
#: negative one)
R_KDIAG, R_FIXED, R_GM, R_RRW, R_RESIDUAL, R_ASYM = range(6)
N_ROWS = 6


@njit(cache=True)
def _quantise(inc: np.ndarray, residual: np.ndarray, q: float) -> None:
    for i in range(inc.shape[0]):
        v = inc[i] + residual[i]
        out = q * np.floor(v / q + 0.5)
        residual[i] = v - out
        inc[i] = out


@njit(cache=True)
def inertial_step(u: np.ndarray, rows: np.ndarray, K: np.ndarray, c: np.ndarray, z: np.ndarray, increment: bool,
                  out: np.ndarray) -> None:
    """One step of an n-axis inertial sensor (``InertialErrorCore``): the bias states
    advanced to the step's end by the normals ``z`` (Gauss-Markov n, then random walk n,
    then white n, each when it applies), then

        y = K u + a ∘ |u| + b_fix + b_gm + b_rrw + (N/√Δt) z,   clamped to ±saturation,

    with K = I + diag(s) + M (``K`` when ``c[I_HAS_K]``, else its diagonal ``rows[R_KDIAG]``)
    and a = ``rows[R_ASYM]`` when ``c[I_HAS_ASYM]`` (a term switched off is not computed, so
    a sensor without it gives the bits it gave before the term existed),

    into ``out`` as the step average (``increment`` False) or the increment y Δt, a quantum
    set quantising the increment with the residual carried (``rows[R_RESIDUAL]``)."""
    n = u.shape[0]
    j = 0
    gm, rrw = rows[R_GM], rows[R_RRW]
    if c[I_HAS_GM] != 0.0:
        for i in range(n):
            gm[i] = c[I_PHI] * gm[i] + c[I_GM_DRIVE] * z[j + i]
        j += n
    if c[I_HAS_RRW] != 0.0:
        for i in range(n):
            rrw[i] += c[I_RRW_DRIVE] * z[j + i]
        j += n
    sat = c[I_SATURATION]
    for i in range(n):
        if c[I_HAS_K] != 0.0:
            y = 0.0
            for k in range(n):
                y += K[i, k] * u[k]
            y = y + rows[R_FIXED, i] + gm[i] + rrw[i]
        else:
            y = rows[R_KDIAG, i] * u[i] + rows[R_FIXED, i] + gm[i] + rrw[i]
        if c[I_HAS_ASYM] != 0.0:
            y += rows[R_ASYM, i] * abs(u[i])
        if c[I_WHITE_SD] > 0.0:
            y += c[I_WHITE_SD] * z[j + i]
        if sat != np.inf:
            y = sat if y > sat else -sat if y < -sat else y
        out[i] = y
    dt, q = c[I_DT], c[I_QUANTUM]
    if increment or q > 0.0:
        for i in range(n):
            out[i] = out[i] * dt
        if q > 0.0:
            _quantise(out, rows[R_RESIDUAL], q)
        if not increment:
            for i in range(n):
                out[i] = out[i] / dt


@njit(cache=True)
def wrap_pi(a: float) -> float:
    """a in (−π, π] (``ins._wrap_pi``)."""
    w = np.fmod(a + math.pi, 2.0 * math.pi)  # exact, as C fmod
    if w <= 0.0:
        w += 2.0 * math.pi
    return w - math.pi


# One row of the INS attitude-error coefficients per Euler angle: Φ (p00, p01, p10, p11) and the
# lower Cholesky factor (l11, l21, l22) of the step's noise covariance; a first-order axis uses
# p00 and l11 only and draws one normal, a second-order axis (θ, θ̇) draws two.
A_P00, A_P01, A_P10, A_P11, A_L11, A_L21, A_L22 = range(7)


@njit(cache=True)
def ins_attitude_error_step(e: np.ndarray, coef: np.ndarray, order: np.ndarray, z: np.ndarray) -> None:
    """One step of the attitude errors ``e`` (3, 2) (θ, θ̇ per Euler angle) with ``coef`` (3, 7),
    ``order`` (3,) (1 or 2) and the sample's normals ``z``, taken in axis order."""
    j = 0
    for i in range(3):
        c = coef[i]
        if order[i] == 1:
            e[i, 0] = c[A_P00] * e[i, 0] + c[A_L11] * z[j]
            j += 1
        else:
            x, v = e[i, 0], e[i, 1]
            e[i, 0] = c[A_P00] * x + c[A_P01] * v + c[A_L11] * z[j]
            e[i, 1] = c[A_P10] * x + c[A_P11] * v + c[A_L21] * z[j] + c[A_L22] * z[j + 1]
            j += 2


@njit(cache=True)
def ins_attitude(e: np.ndarray, coef: np.ndarray, order: np.ndarray, z: np.ndarray, roll: float, pitch: float,
                 yaw: float) -> tuple:
    """The measured Euler angles from the true ones, after one step of the attitude errors
    (:func:`ins_attitude_error_step`)."""
    ins_attitude_error_step(e, coef, order, z)
    return roll + e[0, 0], pitch + e[1, 0], wrap_pi(yaw + e[2, 0])
