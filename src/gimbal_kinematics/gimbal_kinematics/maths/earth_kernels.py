"""Compiled per-sample kernels of the WGS-84 earth (numba ``njit``): plain functions of
floats, no checks (:mod:`.earth` checks the latitude, then calls these, so the navigator's
compiled step and every other caller compute the same radii and gravity); the constants are
:mod:`.wgs84`'s."""
from __future__ import annotations

import math

from numba import njit

from .wgs84 import A, E2, F, GAMMA_E, M, SOMIGLIANA_K


@njit(cache=True)
def meridian_radius(lat: float) -> float:
    """R_M = a (1 − e²) / (1 − e² sin² L)^(3/2) [m]."""
    return A * (1.0 - E2) / (1.0 - E2 * math.sin(lat) ** 2) ** 1.5


@njit(cache=True)
def prime_vertical_radius(lat: float) -> float:
    """R_N = a / √(1 − e² sin² L) [m]."""
    return A / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)


@njit(cache=True)
def normal_gravity(lat: float, h: float) -> float:
    """Somigliana's normal gravity at L, second order in the height h [m/s²]:
    γ₀ = γ_e (1 + k sin² L) / √(1 − e² sin² L),
    γ = γ₀ (1 − 2/a (1 + f + m − 2 f sin² L) h + 3 h²/a²)."""
    s2 = math.sin(lat) ** 2
    g0 = GAMMA_E * (1.0 + SOMIGLIANA_K * s2) / math.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A * (1.0 + F + M - 2.0 * F * s2) * h + 3.0 * h * h / A**2)
