"""Paper 3's pair of dynamically tuned gyros on the stable element, simulated.

The rotor kinematics and the torquer are :mod:`gimbal_kinematics.maths.dtg`; this module adds
what the world draws and the processor never sees:

* the drift truth: a g-insensitive drift per sensitive axis, drawn once per run
  (σ ``drift_sigma_deg_h``: paper 3 §2 gives the gyros' accuracy as 0.03 °/h) plus a given
  part, and the g-sensitive matrix where a data sheet gives one;
* the rotor's random walk: white drift noise of density ``arw_deg_rt_h`` integrated by the
  rotor (one N(0, arw²/dt) rate sample per step, held over the step: the pickoff then walks
  by arw·√dt per step);
* the torquer scale-factor error per axis (``scale_error_ppm``), which the processor's
  current command does not know;
* white pickoff read-out noise (``pickoff_noise_arcsec``; 0: the pickoff amplifier and the
  24-bit ADS1274 of §3 resolve far below the loop's error).

Inputs per step: the platform's inertial rate ω_is^s and specific force f_s held over the step
(the plant's truth), and the torquer currents (x_s, y_s, z_s) [A] that the servo commanded at
the step's start (the lower gyro takes x, y; the upper gyro x, z, :func:`~gimbal_kinematics.
maths.dtg.torquer_rates`). Output: the four pickoffs (lower X_g, Y_g; upper X′_g, Y_g) [rad].
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from gimbal_kinematics.maths import dtg
from gimbal_kinematics.maths.rotations import quat_conj, quat_from_rotation_vector, quat_mul, rotation_vector_from_quat
from gimbal_kinematics.maths.units import ARCSEC, DEG_H, DEG_RT_H


@dataclass(frozen=True)
class DtgPairParams:
    """The two DTGs' errors in the edge's units (validated by :class:`~gimbal_kinematics.
    maths.dtg.DtgParams` once drawn). ``*_ppm``, ``drift_deg_h``: lower (x, y), upper (x, y)."""

    scale_deg_h_ma: float = dtg.PAPER_TORQUER_SCALE_DEG_H_MA
    scale_error_ppm: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    drift_deg_h: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    drift_sigma_deg_h: float = 0.03
    drift_g_deg_h_g: tuple[tuple[float, ...], ...] = ((0.0,) * 3,) * 4
    arw_deg_rt_h: float = 0.003
    pickoff_noise_arcsec: float = 0.0
    max_current_ma: float = 200.0

    def __post_init__(self) -> None:
        for name in ("scale_error_ppm", "drift_deg_h"):
            if len(getattr(self, name)) != 4:
                raise ValueError(f"{name} needs 4 values (lower x, y, upper x, y)")
        if len(self.drift_g_deg_h_g) != 4 or any(len(r) != 3 for r in self.drift_g_deg_h_g):
            raise ValueError("drift_g_deg_h_g needs 4 rows of 3 (lower x, y, upper x, y; on f_c)")
        for name in ("drift_sigma_deg_h", "arw_deg_rt_h", "pickoff_noise_arcsec"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"{name} must be >= 0, got {v!r}")


def _to_case(c_sc: np.ndarray, v_s: Sequence[float]) -> tuple[float, float, float]:
    """C_sc^T v_s in plain floats (per step, where small numpy products cost more than the maths)."""
    x, y, z = float(v_s[0]), float(v_s[1]), float(v_s[2])
    return tuple(c_sc[0][j] * x + c_sc[1][j] * y + c_sc[2][j] * z for j in range(3))


class DtgPair:
    """The lower and upper DTGs of paper 3 (module docstring); seeded by ``rng``."""

    MOUNTS = (dtg.LOWER_C_SC.tolist(), dtg.UPPER_C_SC.tolist())

    def __init__(self, params: DtgPairParams, rng: np.random.Generator) -> None:
        self.params = params
        self.rng = rng
        drawn = np.asarray(params.drift_deg_h) + params.drift_sigma_deg_h * rng.standard_normal(4)
        e, g = params.scale_error_ppm, params.drift_g_deg_h_g
        self.gyros = tuple(dtg.DtgParams.from_units(params.scale_deg_h_ma, e[2 * j:2 * j + 2],
                                                    drawn[2 * j:2 * j + 2].tolist(), g[2 * j:2 * j + 2],
                                                    params.max_current_ma) for j in (0, 1))
        self.h = [(0.0, 0.0, 1.0), (0.0, 0.0, 1.0)]
        self._arw = params.arw_deg_rt_h * DEG_RT_H
        self._pick_sigma = params.pickoff_noise_arcsec * ARCSEC

    def drift_truth(self) -> tuple[float, float, float, float]:
        """The g-insensitive drifts (lower x, y, upper x, y) [rad/s] drawn for this run."""
        return (*self.gyros[0].drift_rad_s, *self.gyros[1].drift_rad_s)

    def drift_truth_s(self) -> tuple[float, float, float]:
        """The same drifts as the platform rates they cause (x_s, y_s from the lower gyro,
        z_s from the upper) [rad/s]: the precession about s of each gyro's reference."""
        lower, upper = self.gyros[0].drift_rad_s, self.gyros[1].drift_rad_s
        return lower[0], lower[1], upper[1]

    def step(self, omega_is_s: Sequence[float], f_s: Sequence[float], currents_s_a: Sequence[float],
             dt: float) -> tuple[float, float, float, float]:
        """Advance ``dt`` [s]; return the pickoffs (lower θ_x, θ_y, upper θ_x, θ_y) [rad]."""
        ix, iy, iz = currents_s_a
        currents = ((ix, iy), (ix, iz))
        noise = self.rng.standard_normal(4) * (self._arw / math.sqrt(dt)) if self._arw > 0.0 else np.zeros(4)
        out = []
        for j, (mount, gyro) in enumerate(zip(self.MOUNTS, self.gyros)):
            w_c, f_c = _to_case(mount, omega_is_s), _to_case(mount, f_s)
            self.h[j] = dtg.step_spin_axis(gyro, self.h[j], w_c, currents[j], f_c, dt, noise[2 * j:2 * j + 2])
            out.extend(dtg.pickoff(self.h[j]))
        if self._pick_sigma > 0.0:
            out = (np.asarray(out) + self._pick_sigma * self.rng.standard_normal(4)).tolist()
        return tuple(out)


class DtgOnPlatform:
    """The pair on the stable element, driven by the platform's attitude truth.

    :meth:`update` takes the platform's attitude q_nm and specific force of step k; from
    k = 1 on it integrates the pair over k−1 → k through the platform's inertial rotation
    over the step, exact for the n frame turning at the constant ``omega_in_n`` [rad/s] (a
    base at rest on the earth), under the currents the servo commanded at k−1 (held over
    the step, as the torquing electronics hold them). The pickoffs of k = 0 are zero: the
    rotors are uncaged onto the platform's axes.
    """

    def __init__(self, pair: DtgPair, omega_in_n: Sequence[float], dt: float) -> None:
        self.pair = pair
        self.dt = dt
        w = [float(v) * dt for v in omega_in_n]
        self._q_earth = quat_from_rotation_vector(w[0], w[1], w[2])
        self._last: tuple[float, ...] | None = None

    def update(self, quat_nm: Sequence[float], f_m: Sequence[float],
               currents_a: Sequence[float] | None) -> tuple[float, float, float, float]:
        """The pickoffs (lower θ_x, θ_y, upper θ_x, θ_y) [rad] of the step whose attitude is
        ``quat_nm``; ``currents_a``: the torquer currents (x_s, y_s, z_s) [A] held over the
        step that ends here (ignored at the first step)."""
        q = tuple(quat_nm)
        if self._last is None:
            out = (0.0, 0.0, 0.0, 0.0)
        else:
            if currents_a is None:
                raise ValueError("the DTG pair needs the torquer currents of the last step")
            # the platform's inertial rotation over the step, in m at its start (a constant-axis rotation exactly)
            rot = rotation_vector_from_quat(*quat_mul(quat_mul(quat_conj(self._last), self._q_earth), q))
            dt = self.dt
            out = self.pair.step(tuple(r / dt for r in rot), f_m, currents_a, dt)
        self._last = q
        return out
