"""Compiled per-sample kernels of the encoder and inertial sensor models (numba ``njit``):
plain functions over float64 arrays, the normals drawn beforehand from the model's own
stream in its order (:func:`draw_normals`). The maths is :mod:`.encoder`'s and
:mod:`.inertial_core`'s docstrings:

    encoder:   c = ⌊θ/δ + ½⌋,  θ̃ = c δ + σ z,  ω̃ = (c − c_ref) δ / T_g every gate (held between)
    inertial:  y = (1 + s) u + b_fix + b_gm + b_rrw + (N/√Δt) z     (step-average, no quantum)

:class:`.encoder.EncoderModel` holds its state in the vector of :func:`encoder_step` and calls
it per sample; the compiled engine (``gimbal_sim.core.compiled_platform``) calls both kernels
over the models' states (``E_*`` for an encoder set).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ._normals import _BLOCK, NormalStream

E_HAS_REF, E_K = 0, 1  # then the reference counts (n) and the held rates (n)


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


@njit(cache=True)
def inertial_rate(u: np.ndarray, kdiag: np.ndarray, fixed: np.ndarray, gm: np.ndarray, rrw: np.ndarray,
                  white_sd: float, z: np.ndarray, out: np.ndarray) -> None:
    """Step-average measurement of an inertial triad with fixed biases, held Gauss-Markov
    and random-walk states and white noise ``white_sd`` · z (``InertialErrorCore.step_rate``
    for a model without misalignment, quantum, saturation or evolving bias states)."""
    for i in range(u.shape[0]):
        y = kdiag[i] * u[i] + fixed[i] + gm[i] + rrw[i]
        if white_sd > 0.0:
            y += white_sd * z[i]
        out[i] = y


def draw_normals(stream: NormalStream, k: int, m: int) -> np.ndarray:
    """The normals of ``m`` successive ``stream.take(k)`` calls as an (m, k) array, the
    stream left as those calls leave it (its blocks of 4096, a block's tail too short for a
    take dropped)."""
    out = np.empty((m, k))
    if k == 0 or m == 0:
        return out
    done = 0
    buf, j = stream._buf, stream._j
    while done < m:
        avail = (len(buf) - j) // k
        if avail == 0:
            buf, j = stream._rng.standard_normal(max(_BLOCK, k)), 0
            continue
        use = min(avail, m - done)
        out[done:done + use] = np.asarray(buf[j:j + use * k]).reshape(use, k)
        done += use
        j += use * k
    stream._buf, stream._j = buf, j
    return out
