"""Compiled per-sample kernel of the sinusoid motion profiles (numba ``njit``).

A profile is packed once into arrays (:func:`pack`): the seven channels' (offset, rate)
in ``lines`` (7, 2), in the order roll, pitch, yaw, ψt, a_x, a_y, a_z, and their terms
(ω, φ, A, Aω, Aω²) concatenated in ``terms`` (n, 5), channel c's rows being
``starts[c]:starts[c + 1]``. :func:`sample` evaluates every channel at t and builds the
host sample with :func:`gimbal_kinematics.gimbal.host_kernels.host_fields`;
:func:`host_truth_rows` gives a block of steps' host truth as the vehicle core computes it.
Each channel::

    x(t) = x₀ + ẋ₀ t + Σ A sin(ω t + φ),  ẋ = ẋ₀ + Σ Aω cos(ω t + φ),  ẍ = −Σ Aω² sin(ω t + φ)
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.gimbal.host_kernels import host_fields, inertial_rates


def pack(channels) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lines, terms, starts) of seven :class:`.motion_profiles.SinusoidChannel` (module
    docstring); a channel's precomputed terms (zero amplitudes dropped) in its order."""
    lines = np.array([(ch.offset, ch.rate) for ch in channels], dtype=float)
    rows = [term for ch in channels for term in ch._terms]
    terms = np.array(rows, dtype=float).reshape(len(rows), 5)
    starts = np.cumsum([0] + [len(ch._terms) for ch in channels]).astype(np.int64)
    return lines, terms, starts


@njit(cache=True)
def channel(lines: np.ndarray, terms: np.ndarray, starts: np.ndarray, c: int, t: float) -> tuple:
    """(x, ẋ, ẍ) of channel ``c`` at ``t`` [s]."""
    x = lines[c, 0] + lines[c, 1] * t
    dx = lines[c, 1]
    ddx = 0.0
    for k in range(starts[c], starts[c + 1]):
        w, ph, a, aw, aw2 = terms[k, 0], terms[k, 1], terms[k, 2], terms[k, 3], terms[k, 4]
        arg = w * t + ph
        s = math.sin(arg)
        x += a * s
        dx += aw * math.cos(arg)
        ddx -= aw2 * s
    return x, dx, ddx


@njit(cache=True)
def sample(lines: np.ndarray, terms: np.ndarray, starts: np.ndarray, t: float) -> tuple:
    """The 22 host-state fields at ``t`` (module docstring)."""
    r0, r1, r2 = channel(lines, terms, starts, 0, t)
    p0, p1, p2 = channel(lines, terms, starts, 1, t)
    y0, y1, y2 = channel(lines, terms, starts, 2, t)
    t0, t1, t2 = channel(lines, terms, starts, 3, t)
    ax = channel(lines, terms, starts, 4, t)[0]
    ay = channel(lines, terms, starts, 5, t)[0]
    az = channel(lines, terms, starts, 6, t)[0]
    return host_fields(t, r0, p0, y0, r1, p1, y1, r2, p2, y2, t0, t1, t2, ax, ay, az)


@njit(cache=True)
def host_truth_rows(lines: np.ndarray, terms: np.ndarray, starts: np.ndarray, k0: int, k1: int, dt: float,
                    wx: float, wy: float, wz: float, g: float, out: np.ndarray) -> None:
    """The host's truth of steps k0 … k1−1 (t = k·dt) into ``out`` (k1 − k0, 9): the Euler
    angles (roll, pitch, yaw), ω_ib^b (the NED frame's inertial rate (wx, wy, wz) added,
    :func:`gimbal_kinematics.gimbal.host_kernels.inertial_rates`) and f_b = a_b − C_bn (0, 0, g),
    in the operation order of :meth:`..vehicle.VehicleCore.truth` (the same floats)."""
    for k in range(k0, k1):
        h = sample(lines, terms, starts, k * dt)
        roll, pitch, yaw = h[1], h[2], h[3]
        cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
        w = inertial_rates(h[10], h[11], h[12], h[13], h[14], h[15], yaw, wx, wy, wz, cr, sr, cp, sp)
        row = out[k - k0]
        row[0], row[1], row[2] = roll, pitch, yaw
        row[3], row[4], row[5] = w[0], w[1], w[2]
        row[6], row[7], row[8] = h[19] - (-sp) * g, h[20] - (sr * cp) * g, h[21] - (cr * cp) * g
