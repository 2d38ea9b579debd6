"""Paper 3's DTG pair on the stable element as a compiled per-step kernel (numba ``njit``),
for the compiled platform chain: :class:`.dtg.DtgOnPlatform`'s step in the same operations,
so a seed gives the same pickoffs in both loops.

Packed state ``s`` (:data:`N_STATE`): the two spin axes h_c (lower, upper), the platform's
last attitude q_nm and whether there is one, and the torquer currents (x_s, y_s, z_s) [A]
held over the step. Parameters ``g`` (2, :data:`N_GYRO`) per gyro: the true torquer scale
factors S (x_c, y_c) [rad/s/A], the drift ε_F (x_c, y_c) [rad/s] and the g-sensitive D_g
(2, 3) row by row; ``mounts`` (2, 3, 3) the gyros' C_sc.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.maths import dtg
from gimbal_kinematics.maths.quat_kernels import quat_conj, quat_mul, rotation_vector_from_quat

rotate = njit(cache=True)(dtg.rotate)
pickoff = njit(cache=True)(dtg.pickoff)

#: state: h lower (3), h upper (3), q_nm of the last step (4), has one, currents (3)
S_H, S_Q, S_HAS_Q, S_I = 0, 6, 10, 11
N_STATE = 14
#: a gyro's parameters: true scale (2), drift (2), D_g (6, row x_c then y_c)
G_SCALE, G_DRIFT, G_DG = 0, 2, 4
N_GYRO = 10


def pack(pair, q_earth, currents) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(state, parameters, mounts, q_earth) of a :class:`.dtg.DtgPair` before its first step."""
    s = np.zeros(N_STATE)
    for j in (0, 1):
        s[S_H + 3 * j:S_H + 3 * j + 3] = pair.h[j]
    s[S_I:S_I + 3] = currents
    g = np.zeros((2, N_GYRO))
    for j, gyro in enumerate(pair.gyros):
        g[j, G_SCALE:G_SCALE + 2] = gyro.true_scale()
        g[j, G_DRIFT:G_DRIFT + 2] = gyro.drift_rad_s
        g[j, G_DG:G_DG + 6] = np.asarray(gyro.drift_g, dtype=float).reshape(6)
    return s, g, np.array(pair.MOUNTS, dtype=float), np.array(q_earth, dtype=float)


@njit(cache=True)
def _to_case(m: np.ndarray, x: float, y: float, z: float) -> tuple:
    """C_sc^T v_s, summed as the Python model sums it."""
    return (m[0, 0] * x + m[1, 0] * y + m[2, 0] * z, m[0, 1] * x + m[1, 1] * y + m[2, 1] * z,
            m[0, 2] * x + m[1, 2] * y + m[2, 2] * z)


@njit(cache=True)
def _gyro_step(s, j, g, m, w_s, f_s, ia, ib, ex0, ex1, dt) -> None:
    """Gyro j's spin axis over the step (``dtg.step_spin_axis``'s operations)."""
    wc = _to_case(m, w_s[0], w_s[1], w_s[2])
    fc = _to_case(m, f_s[0], f_s[1], f_s[2])
    tx, ty = g[G_SCALE] * ia, g[G_SCALE + 1] * ib
    e0 = g[G_DRIFT] + g[G_DG] * fc[0] + g[G_DG + 1] * fc[1] + g[G_DG + 2] * fc[2]
    e1 = g[G_DRIFT + 1] + g[G_DG + 3] * fc[0] + g[G_DG + 4] * fc[1] + g[G_DG + 5] * fc[2]
    w = (tx + e0 + ex0 - wc[0], ty + e1 + ex1 - wc[1], -wc[2])
    a = S_H + 3 * j
    hx, hy, hz = rotate((s[a], s[a + 1], s[a + 2]), w, dt)
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    s[a], s[a + 1], s[a + 2] = hx / n, hy / n, hz / n


@njit(cache=True)
def dtg_update(s, g, mounts, q_earth, q, f_s, dt, arw_sd, pick_sd, z, out) -> None:
    """The pair's pickoffs (lower θ_x, θ_y, upper θ_x, θ_y) [rad] into ``out`` at the step
    whose attitude is ``q`` (x, y, z, w) and specific force ``f_s``: zero at the first step;
    then the pair turned through the platform's inertial rotation since the last step under
    the held currents. ``z``: the step's normals (the rotors' drift noise, times ``arw_sd``,
    then the read-out noise, times ``pick_sd``, each only where its σ is not zero)."""
    if s[S_HAS_Q] == 0.0:
        out[0] = out[1] = out[2] = out[3] = 0.0
    else:
        last = (s[S_Q], s[S_Q + 1], s[S_Q + 2], s[S_Q + 3])
        qe = (q_earth[0], q_earth[1], q_earth[2], q_earth[3])
        rot = rotation_vector_from_quat(*quat_mul(quat_mul(quat_conj(last), qe), (q[0], q[1], q[2], q[3])))
        w_s = (rot[0] / dt, rot[1] / dt, rot[2] / dt)
        ex = np.zeros(4)
        used = 0
        if arw_sd > 0.0:
            for i in range(4):
                ex[i] = z[i] * arw_sd
            used = 4
        ix, iy, iz = s[S_I], s[S_I + 1], s[S_I + 2]
        _gyro_step(s, 0, g[0], mounts[0], w_s, f_s, ix, iy, ex[0], ex[1], dt)
        _gyro_step(s, 1, g[1], mounts[1], w_s, f_s, ix, iz, ex[2], ex[3], dt)
        for j in (0, 1):
            a = S_H + 3 * j
            out[2 * j], out[2 * j + 1] = pickoff((s[a], s[a + 1], s[a + 2]))
        if pick_sd > 0.0:
            for i in range(4):
                out[i] = out[i] + pick_sd * z[used + i]
    s[S_Q], s[S_Q + 1], s[S_Q + 2], s[S_Q + 3] = q[0], q[1], q[2], q[3]
    s[S_HAS_Q] = 1.0
