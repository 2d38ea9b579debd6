"""WGS-84 and earth constants, in one place: :mod:`.earth` (checked functions) and
:mod:`.earth_kernels` (their compiled arithmetic) both read them from here."""
from __future__ import annotations

#: WGS-84 semi-major axis [m].
A = 6378137.0
#: WGS-84 flattening [-].
F = 1.0 / 298.257223563
#: First eccentricity squared [-].
E2 = F * (2.0 - F)
#: Semi-minor axis [m].
B = A * (1.0 - F)
#: Earth rotation rate [rad/s] (docs/spec.md §2).
OMEGA_IE = 7.292115e-5
#: Earth gravitational constant GM [m³/s²].
GM = 3.986004418e14
#: Normal gravity at the equator and the Somigliana constant.
GAMMA_E = 9.7803253359
SOMIGLIANA_K = 0.00193185265241
#: m = ω² a² b / GM of Somigliana's height term.
M = OMEGA_IE**2 * A**2 * B / GM
