"""WGS-84 earth: constants, radii of curvature, earth and transport rate, normal gravity.

Navigation frame ``n`` is local-level NED. Latitude ``lat`` and longitude ``lon`` are
geodetic [rad], height ``h`` is above the ellipsoid [m], velocities are [m/s].
"""
from __future__ import annotations

import math

import numpy as np

from .wgs84 import A, B, E2, F, GAMMA_E, GM, OMEGA_IE, SOMIGLIANA_K  # noqa: F401  (re-exported)


def _check_lat(lat: float) -> None:
    if not math.isfinite(lat) or abs(lat) > math.pi / 2:
        raise ValueError(f"latitude {lat!r} rad is outside [-π/2, π/2]")


def meridian_radius(lat: float) -> float:
    """Meridian radius of curvature R_M [m] at geodetic latitude ``lat`` [rad]."""
    _check_lat(lat)
    from . import earth_kernels as ek  # lazily: numba loads only where a kernel runs

    return ek.meridian_radius(float(lat))


def prime_vertical_radius(lat: float) -> float:
    """Prime-vertical (transverse) radius of curvature R_N [m] at ``lat`` [rad]."""
    _check_lat(lat)
    from . import earth_kernels as ek  # lazily: numba loads only where a kernel runs

    return ek.prime_vertical_radius(float(lat))


def earth_rate_n(lat: float) -> np.ndarray:
    """Earth rate ω_ie resolved in NED [rad/s]: Ω (cos L, 0, -sin L); shape (3,)."""
    _check_lat(lat)
    return OMEGA_IE * np.array([math.cos(lat), 0.0, -math.sin(lat)])


def transport_rate_n(lat: float, h: float, v_n: np.ndarray) -> np.ndarray:
    """Transport rate ω_en resolved in NED [rad/s] for NED velocity ``v_n`` [m/s]; (3,).

    ω_en = (v_E / (R_N + h), -v_N / (R_M + h), -v_E tan L / (R_N + h)). Raises
    ``ValueError`` at the poles, where the east-axis rate is unbounded.
    """
    _check_lat(lat)
    if abs(math.cos(lat)) < 1e-9:
        raise ValueError("transport_rate_n: undefined at the poles (tan L is unbounded)")
    v_north, v_east = float(v_n[0]), float(v_n[1])
    rn = prime_vertical_radius(lat) + h
    rm = meridian_radius(lat) + h
    return np.array([v_east / rn, -v_north / rm, -v_east * math.tan(lat) / rn])


def normal_gravity(lat: float, h: float = 0.0) -> float:
    """Magnitude of WGS-84 normal gravity [m/s²] (Somigliana, second-order in height)."""
    _check_lat(lat)
    from . import earth_kernels as ek  # lazily: numba loads only where a kernel runs

    return ek.normal_gravity(float(lat), float(h))


def gravity_n(lat: float, h: float = 0.0) -> np.ndarray:
    """Normal gravity vector in NED [m/s²]; points down (+z); shape (3,)."""
    return np.array([0.0, 0.0, normal_gravity(lat, h)])


def ecef_from_geodetic(lat: float, lon: float, h: float = 0.0) -> np.ndarray:
    """Earth-centred earth-fixed position [m] of a geodetic point; shape (3,)."""
    rn = prime_vertical_radius(lat)
    cl = math.cos(lat)
    return np.array(
        [(rn + h) * cl * math.cos(lon), (rn + h) * cl * math.sin(lon), (rn * (1 - E2) + h) * math.sin(lat)]
    )


def enu_from_geodetic(lat: float, lon: float, h: float, lat0: float, lon0: float, h0: float
                      ) -> tuple[float, float, float]:
    """East, north, up [m] of a geodetic point in the local ENU frame whose origin is the
    geodetic point (lat0, lon0, h0) [rad, m]: the ECEF difference resolved at the origin.
    Scalar Python (not a numpy product), so the bits do not depend on the CPU's BLAS."""
    a = ecef_from_geodetic(lat, lon, h)
    b = ecef_from_geodetic(lat0, lon0, h0)
    dx, dy, dz = float(a[0] - b[0]), float(a[1] - b[1]), float(a[2] - b[2])
    sl, cl = math.sin(lat0), math.cos(lat0)
    so, co = math.sin(lon0), math.cos(lon0)
    east = -so * dx + co * dy
    north = -sl * co * dx - sl * so * dy + cl * dz
    up = cl * co * dx + cl * so * dy + sl * dz
    return east, north, up


def dcm_en(lat: float, lon: float) -> np.ndarray:
    """``C_en``: NED navigation frame to ECEF at (lat, lon) [rad]; shape (3, 3)."""
    sl, cl = math.sin(lat), math.cos(lat)
    so, co = math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -so, -cl * co], [-sl * so, co, -cl * so], [cl, 0.0, -sl]])
