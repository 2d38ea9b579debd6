"""Two-degree-of-freedom dynamically tuned gyro (DTG) and its torquer (paper 3 §2, §2.1.1).

A tuned DTG's rotor, below its nutation frequency, is a free gyro: its spin axis h keeps its
inertial direction except where the torquer precesses it. In the case frame c (x_c, y_c the
two sensitive axes, z_c the nominal spin axis) the unit spin axis h_c therefore moves as::

    ḣ_c = (ω_tq + ε − ω_ic^c) × h_c

with ω_ic^c the case's inertial rate, ε the drift (the rotor's unwanted precession) and
ω_tq = (S_x i_x, S_y i_y, 0) the torquer's precession: currents i [A] times the true torquer
scale factors S = S_nom (1 + e_sf) [rad/s/A]. For rates held over a step this is an exact
rotation of h_c about (ω_tq + ε − ω_ic^c) (:func:`rotate`), so a run is exact for
piecewise-constant rates, however large the tilt. The spin-axis component of ω_ic^c turns
the tilt with the case, as a real DTG's pickoff frame does.

Pickoff angles (the rotor's tilt against the case about x_c and y_c, what the pickoff coils
read)::

    θ_x = atan2(−h_y, h_z),   θ_y = atan2(h_x, h_z)

so a precession by α about x_c alone reads θ_x = α exactly.

Drift ε = ε_F + D_g f_c: a g-insensitive term ε_F (2,) [rad/s] and a g-sensitive matrix
D_g (2, 3) [rad/s per m/s²] on the specific force in c (mass unbalance and quadrature, IEEE
Std 813-1988's D_F and D_I, D_S terms). A data sheet gives them per gyro; zero where none does.

Mounting (paper 3 §2.1.2, Fig. 3), as :data:`LOWER_C_SC` and :data:`UPPER_C_SC` (C_sc: case
to platform s): the lower gyro spins along z_s, its X_g and Y_g read the platform's tilt about
x_s and y_s (the level loops). The upper gyro spins horizontally along −y_s; its x_c is x_s
(X′_g, the redundant axis used for the platform lock) and its y_c is z_s (its Y_g drives the
azimuth loop). Two DTGs: four pickoffs, three sensitive axes, one redundant.

Torquer scale factor. Paper 3 gives no data sheet; its own numbers fix it: the azimuth
torquer carries 60 mA while the platform turns at 1.2 °/s (§4.1, Fig. 6b), so
S = 1.2·3600 °/h / 60 mA = 72 (°/h)/mA (:data:`PAPER_TORQUER_SCALE_DEG_H_MA`; the vertical
earth rate adds ±10.8 °/h at 45°, 0.15 mA, inside the figure's rounding).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .units import DEG_H, G0

#: Paper 3's own torquer scale factor [(°/h)/mA]: 1.2 °/s = 4320 °/h at 60 mA (module docstring).
PAPER_TORQUER_SCALE_DEG_H_MA = 4320.0 / 60.0
#: (°/h)/mA -> rad/s/A
DEG_H_PER_MA = DEG_H * 1000.0

#: case -> platform of the lower gyro (spin along z_s; X_g, Y_g about x_s, y_s)
LOWER_C_SC = np.eye(3)
#: case -> platform of the upper gyro (x_c = x_s: X′_g; y_c = z_s: the azimuth Y_g; spin −y_s)
UPPER_C_SC = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def rotate(h: Sequence[float], w: Sequence[float], dt: float) -> tuple[float, float, float]:
    """h turned by the rate ``w`` held for ``dt`` (Rodrigues: the exact solution of ḣ = w × h)."""
    wx, wy, wz = w
    n = math.sqrt(wx * wx + wy * wy + wz * wz)
    if n == 0.0:
        return float(h[0]), float(h[1]), float(h[2])
    a = n * dt
    kx, ky, kz = wx / n, wy / n, wz / n
    hx, hy, hz = h
    c, s = math.cos(a), math.sin(a)
    kdh = (kx * hx + ky * hy + kz * hz) * (1.0 - c)
    cx, cy, cz = ky * hz - kz * hy, kz * hx - kx * hz, kx * hy - ky * hx
    return (hx * c + cx * s + kx * kdh, hy * c + cy * s + ky * kdh, hz * c + cz * s + kz * kdh)


def pickoff(h: Sequence[float]) -> tuple[float, float]:
    """The pickoff angles (θ_x, θ_y) [rad] of the spin axis h_c (module docstring)."""
    return math.atan2(-h[1], h[2]), math.atan2(h[0], h[2])


def spin_axis(theta_x: float, theta_y: float) -> tuple[float, float, float]:
    """The unit spin axis h_c whose pickoffs are (θ_x, θ_y) (inverse of :func:`pickoff`)."""
    tx, ty = math.tan(theta_x), math.tan(theta_y)
    n = math.sqrt(1.0 + tx * tx + ty * ty)
    return ty / n, -tx / n, 1.0 / n


@dataclass(frozen=True)
class DtgParams:
    """One DTG (SI inside; built from the edge's units by :meth:`from_units`).

    Attributes:
        scale_rad_s_a: nominal torquer scale factor S_nom (x_c, y_c) [rad/s/A].
        scale_error: the true scale factor's relative error e_sf (x_c, y_c) [-].
        drift_rad_s: g-insensitive drift ε_F (x_c, y_c) [rad/s].
        drift_g: g-sensitive drift D_g (2, 3) [rad/s per m/s²] on f_c.
        max_current_a: torquer current limit [A] (the torquing electronics' range).
    """

    scale_rad_s_a: tuple[float, float]
    scale_error: tuple[float, float] = (0.0, 0.0)
    drift_rad_s: tuple[float, float] = (0.0, 0.0)
    drift_g: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.0,) * 3, (0.0,) * 3)
    max_current_a: float = 0.2

    def __post_init__(self) -> None:
        for name in ("scale_rad_s_a", "scale_error", "drift_rad_s"):
            v = getattr(self, name)
            if len(v) != 2 or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name} must be 2 finite numbers (x_c, y_c), got {v!r}")
        if not all(s > 0.0 for s in self.scale_rad_s_a):
            raise ValueError(f"scale_rad_s_a must be > 0, got {self.scale_rad_s_a!r}")
        if not all(e > -1.0 for e in self.scale_error):
            raise ValueError(f"scale_error must be > -1, got {self.scale_error!r}")
        g = np.asarray(self.drift_g, dtype=float)
        if g.shape != (2, 3) or not np.all(np.isfinite(g)):
            raise ValueError(f"drift_g must be a finite 2x3 matrix, got {self.drift_g!r}")
        if not (math.isfinite(self.max_current_a) and self.max_current_a > 0.0):
            raise ValueError(f"max_current_a must be > 0, got {self.max_current_a!r}")

    @classmethod
    def from_units(cls, scale_deg_h_ma: float, scale_error_ppm: Sequence[float] = (0.0, 0.0),
                   drift_deg_h: Sequence[float] = (0.0, 0.0),
                   drift_g_deg_h_g: Sequence[Sequence[float]] = ((0.0,) * 3, (0.0,) * 3),
                   max_current_ma: float = 200.0) -> DtgParams:
        """From the data sheet's units: (°/h)/mA, ppm, °/h, (°/h)/g, mA."""
        return cls(scale_rad_s_a=(scale_deg_h_ma * DEG_H_PER_MA,) * 2,
                   scale_error=tuple(e * 1e-6 for e in scale_error_ppm),
                   drift_rad_s=tuple(d * DEG_H for d in drift_deg_h),
                   drift_g=tuple(tuple(v * DEG_H / G0 for v in row) for row in drift_g_deg_h_g),
                   max_current_a=max_current_ma * 1e-3)

    def true_scale(self) -> tuple[float, float]:
        """S = S_nom (1 + e_sf) per sensitive axis [rad/s/A]."""
        return tuple(s * (1.0 + e) for s, e in zip(self.scale_rad_s_a, self.scale_error))

    def drift(self, f_c: Sequence[float]) -> tuple[float, float]:
        """ε = ε_F + D_g f_c (x_c, y_c) [rad/s] at the specific force ``f_c`` [m/s²]."""
        g = self.drift_g
        return tuple(self.drift_rad_s[i] + g[i][0] * f_c[0] + g[i][1] * f_c[1] + g[i][2] * f_c[2] for i in (0, 1))

    def current_for(self, rate_rad_s: float, axis: int) -> float:
        """The current [A] the processor commands for a precession ``rate_rad_s`` about
        sensitive axis ``axis`` (0: x_c, 1: y_c) with the *nominal* scale factor, clipped."""
        i = rate_rad_s / self.scale_rad_s_a[axis]
        return max(-self.max_current_a, min(self.max_current_a, i))


def precession_rate(params: DtgParams, currents_a: Sequence[float]) -> tuple[float, float]:
    """The torquer's precession (x_c, y_c) [rad/s] for the currents [A] (true scale factors)."""
    sx, sy = params.true_scale()
    return sx * currents_a[0], sy * currents_a[1]


def step_spin_axis(params: DtgParams, h_c: Sequence[float], omega_ic_c: Sequence[float],
                   currents_a: Sequence[float], f_c: Sequence[float], dt: float,
                   extra_rad_s: Sequence[float] = (0.0, 0.0)) -> tuple[float, float, float]:
    """h_c after ``dt`` [s] with the case rate ω_ic^c (3,) [rad/s], the torquer currents
    (2,) [A] and the specific force f_c (3,) [m/s²] held; ``extra_rad_s`` (2,) adds a random
    drift sample (the simulation's noise). Renormalised against round-off."""
    tx, ty = precession_rate(params, currents_a)
    ex, ey = params.drift(f_c)
    w = (tx + ex + extra_rad_s[0] - omega_ic_c[0], ty + ey + extra_rad_s[1] - omega_ic_c[1], -omega_ic_c[2])
    hx, hy, hz = rotate(h_c, w, dt)
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    return hx / n, hy / n, hz / n


def platform_deviation(lower: Sequence[float], upper: Sequence[float]) -> tuple[float, float, float, float]:
    """The platform's dip angles δ (x_s, y_s, z_s) from the gyro references, and the redundant
    x_s from the upper gyro, from the pickoffs (θ_x, θ_y) of the lower and upper gyros: the case
    turned by −θ against its rotor (paper 3 eq. 1's Δθ_g, to first order)."""
    return -lower[0], -lower[1], -upper[1], -upper[0]


def torquer_rates(omega_c_s: Sequence[float]) -> tuple[tuple[float, float], tuple[float, float]]:
    """The precession rates (x_c, y_c) [rad/s] of the lower and upper gyros that make both
    references turn at the command ω_c (x, y, z in s): the lower gyro takes (x, y), the upper
    takes (x, z) (its x_c is the redundant x_s, torqued alike so that X′_g stays at null)."""
    x, y, z = omega_c_s
    return (x, y), (x, z)
