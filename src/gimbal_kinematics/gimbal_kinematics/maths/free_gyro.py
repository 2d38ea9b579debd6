"""Free-gyro positioning and directional geometry (paper 4, docs/spec.md §3.4).

Frames
------
* Inertial ``i`` (earth-centred): x_i points to the Greenwich meridian at t = 0 (in the
  equatorial plane), z_i along the earth's spin axis (north), y_i completes the right-handed
  triad. The earth turns about z_i at ``omega_ie`` [rad/s], so a meridian of longitude λ lies
  at inertial longitude Λ = λ + ω_e t, and ``C_in(φ, λ, t) = dcm_en(φ, λ + ω_e t)``.
* Navigation ``n``: local-level NED; body ``b``: FRD with 3-2-1 Euler angles (roll, pitch,
  heading ψ), as in :mod:`gimbal_kinematics.maths.rotations`.

A free gyro keeps its spin axis ``u_i`` fixed in ``i`` (unit vector, inertial components
u_x, u_y, u_z).

Nadir angle (eq. 1)
-------------------
The local up unit vector in ``i`` is r = (cos φ cos Λ, cos φ sin Λ, sin φ), the nadir is
d = −r, and the nadir angle θ is the angle between u and d::

    cos θ = u·d = −u_x cos φ cos Λ − u_y cos φ sin Λ − u_z sin φ.

Latitude: the paper assumes a spherical earth. Because a gyro vector is a *direction* (no
parallax), only the direction of the vertical matters, and r above is exactly the normal of
the WGS-84 ellipsoid when φ is the **geodetic** latitude. So every function here uses
geodetic φ, the forward model and the fix are mutually consistent, and they agree with the NED
frame of :mod:`gimbal_kinematics.maths.earth`. (A real level reference follows the plumb line, which
differs from the ellipsoid normal by the deflection of the vertical, ~10″; ignored here.)

Azimuth (eq. 2)
---------------
The NED components of u are N_p = u·N, E_p = u·E, D_p = u·d with
N = ∂r/∂φ = (−sin φ cos Λ, −sin φ sin Λ, cos φ) and E = (−sin Λ, cos Λ, 0), so
tan α = E_p / N_p and the horizontal projection of u is sin θ (cos α, sin α).

Position fix
------------
Two gyros give r·u_a = −cos θ_a and r·u_b = −cos θ_b with |r| = 1: the intersection of two
small circles on the unit sphere. Writing r = x u_a + y u_b + z (u_a × u_b) with
g = u_a·u_b, the two linear equations give x, y in closed form and |r| = 1 gives z = ±…,
i.e. two mirror-image solutions about the plane of u_a, u_b. The circles cross at the
angle Δα = α_b − α_a (the angle between the horizontal projections of the two gyro vectors)
and, with w = u_a × u_b, ``r·w = −sin θ_a sin θ_b sin Δα``. Hence the branch is fixed either
by a prior position (nearest candidate) or by the *sense* of Δα, which the platform measures
in the body frame without knowing its position or heading (Δα = ζ_b − ζ_a, the difference of
the gyro azimuths from the ship's head, paper Fig. 4).

Error model (eq. 30–38)
-----------------------
Perturbing eq. 1: −sin θ δθ = −N_p δφ − cos φ E_p δλ, so the perturbation matrix of the nadir
angles is ``W = ∂(θ_a, θ_b)/∂(φ, λ)`` with rows (cos α_k, cos φ sin α_k). The paper writes
eq. 31 in units of the cosine perturbation (rows −sin θ_k times these); with the nadir-angle
errors themselves i.i.d. of standard deviation σ (eq. 34), cov(Δx) = σ² (WᵀW)⁻¹ (eq. 35).
The paper's FDOP = √(q_φφ + q_λλ) (eq. 37) adds radians of latitude to radians of longitude,
which grows as sec φ toward the poles without any position error in metres. The meaningful
form scales longitude by cos φ, Δx = (δφ, cos φ δλ) (north and east arcs, radians of great
circle); its W has rows (cos α_k, sin α_k) and its FDOP = √2 / |sin Δα|, independent of φ.
Both are returned by :func:`fix_geometry`; ``fdop`` is the arc form and
``position_error_m`` multiplies by the radii of curvature. A clock error δt is equivalent to a
longitude error δλ = −ω_e δt (only λ + ω_e t enters eq. 1).

Heading (eq. 3–4, 29)
---------------------
With the body levelled (roll, pitch removed), the earth rate Ω (cos φ, 0, −sin φ)_n appears in
the heading-only frame l as ω_l = rot3(ψ) ω_n = Ω (cos φ cos ψ, −cos φ sin ψ, −sin φ): the
fore-aft component is Ω cos φ cos ψ and the *rightward* (FRD y) component is −Ω cos φ sin ψ.
Paper eq. 3 writes the athwartship component as +Ω cos φ sin ψ, i.e. positive to port; in
FRD the heading (from north toward east) is ψ = atan2(−ω_ly, ω_lx). Its first-order error
(paper eq. 29, rewritten with ω² sec² ψ = ω_lx² + ω_ly²) is
δψ = (ω_ly δω_lx − ω_lx δω_ly) / (ω_lx² + ω_ly²).

All angles in radians, rates in rad/s, time in seconds, distances in metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np

from .earth import OMEGA_IE, dcm_en, meridian_radius, prime_vertical_radius

Vector3 = Union[Sequence[float], np.ndarray]

#: Largest |‖u‖ − 1| accepted for a gyro spin-axis unit vector (it is then renormalised).
UNIT_TOL = 1e-6
#: Horizontal projection of a gyro vector below which its azimuth is undefined (vertical gyro).
VERTICAL_SIN_TOL = 1e-12
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class FixTolerances:
    """Conditioning limits of the two-gyro fix (dimensionless sines).

    ``min_sin_gyro_separation``: |sin| of the angle between u_a and u_b below which the gyro
    vectors count as parallel/antiparallel (concentric circles, no unique fix).
    ``min_sin_crossing_angle``: |sin Δα| below which the two nadir circles count as tangent
    (FDOP = √2/|sin Δα| would exceed √2 / this value).
    """

    min_sin_gyro_separation: float = 1e-6
    min_sin_crossing_angle: float = 1e-6

    def __post_init__(self) -> None:
        for name in ("min_sin_gyro_separation", "min_sin_crossing_angle"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0.0 < value < 1.0):
                raise ValueError(f"{name} must be in (0, 1), got {value!r}")


DEFAULT_TOLERANCES = FixTolerances()


# --- input checks --------------------------------------------------------------------------
def unit_vector(u: Vector3, name: str) -> tuple[float, float, float]:
    """``u`` as a (re-normalised) unit 3-vector; raises ``ValueError`` naming ``name``
    when it is not three numbers or its norm is off 1 by more than ``UNIT_TOL``."""
    try:
        x, y, z = (float(c) for c in u)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a 3-vector of numbers, got {u!r}") from exc
    norm = math.sqrt(x * x + y * y + z * z)
    if not math.isfinite(norm) or abs(norm - 1.0) > UNIT_TOL:
        raise ValueError(f"{name} must be a unit vector, got norm {norm:.9g}")
    return x / norm, y / norm, z / norm


def _check_lat_lon_t(lat: float, lon: float, t: float) -> None:
    if not math.isfinite(lat) or abs(lat) > math.pi / 2:
        raise ValueError(f"lat must be in [-π/2, π/2] rad, got {lat!r}")
    if not math.isfinite(lon):
        raise ValueError(f"lon must be finite, got {lon!r}")
    if not math.isfinite(t):
        raise ValueError(f"t must be finite, got {t!r}")


def _check_nadir(theta: float, name: str) -> float:
    theta = float(theta)
    if not math.isfinite(theta) or not 0.0 <= theta <= math.pi:
        raise ValueError(f"{name} must be a nadir angle in [0, π] rad, got {theta!r}")
    return theta


def wrap_pi(angle: float) -> float:
    """Angle wrapped to [−π, π) [rad]."""
    return (angle + math.pi) % _TWO_PI - math.pi


# --- forward model -------------------------------------------------------------------------
def _ned_components(
    u: tuple[float, float, float], lat: float, lon: float, t: float, omega_ie: float
) -> tuple[float, float, float]:
    ux, uy, uz = u
    big_lambda = lon + omega_ie * t
    sl, cl = math.sin(lat), math.cos(lat)
    so, co = math.sin(big_lambda), math.cos(big_lambda)
    horiz = ux * co + uy * so  # u on the equatorial direction of the meridian
    north = -sl * horiz + cl * uz
    east = -ux * so + uy * co
    down = -cl * horiz - sl * uz
    return north, east, down


def dcm_ni(lat: float, lon: float, t: float, omega_ie: float = OMEGA_IE) -> np.ndarray:
    """``C_ni``: inertial frame to NED at geodetic (lat, lon) [rad] and time t [s]; (3, 3)."""
    _check_lat_lon_t(lat, lon, t)
    return dcm_en(lat, lon + omega_ie * t).T


def gyro_vector_n(
    u_i: Vector3, lat: float, lon: float, t: float, omega_ie: float = OMEGA_IE
) -> np.ndarray:
    """Gyro spin-axis unit vector resolved in NED, (N_p, E_p, D_p); shape (3,)."""
    _check_lat_lon_t(lat, lon, t)
    return np.array(_ned_components(unit_vector(u_i, "u_i"), lat, lon, t, omega_ie))


def nadir_angle(u_i: Vector3, lat: float, lon: float, t: float, omega_ie: float = OMEGA_IE) -> float:
    """Nadir angle θ [rad] in [0, π] of gyro vector ``u_i`` (unit, (3,)) — paper eq. 1.

    ``lat``, ``lon`` geodetic [rad], ``t`` [s] since Greenwich was on x_i.
    """
    _check_lat_lon_t(lat, lon, t)
    north, east, down = _ned_components(unit_vector(u_i, "u_i"), lat, lon, t, omega_ie)
    # atan2 keeps full precision near θ = 0 and π, where acos(cos θ) does not.
    return math.atan2(math.hypot(north, east), down)


def gyro_azimuth(u_i: Vector3, lat: float, lon: float, t: float, omega_ie: float = OMEGA_IE) -> float:
    """Azimuth α [rad] in (−π, π] of the gyro vector from north toward east — paper eq. 2.

    Raises ``ValueError`` when the gyro vector is along the local vertical.
    """
    _check_lat_lon_t(lat, lon, t)
    north, east, _ = _ned_components(unit_vector(u_i, "u_i"), lat, lon, t, omega_ie)
    if math.hypot(north, east) < VERTICAL_SIN_TOL:
        raise ValueError("gyro azimuth undefined: the gyro vector is along the local vertical")
    return math.atan2(east, north)


# --- setting up spin axes ------------------------------------------------------------------
def spin_axis_for_site(lat: float, lon: float, t: float, nadir: float, azimuth: float,
                       omega_ie: float | None = None) -> tuple[float, float, float]:
    """Inertial spin axis u_i (unit) that has nadir angle ``nadir`` and azimuth ``azimuth``
    [rad] (from north toward east) at (lat, lon) [rad] and time ``t`` [s]; for setting up a
    scenario's spin-axis geometry."""
    u_n = np.array([math.sin(nadir) * math.cos(azimuth), math.sin(nadir) * math.sin(azimuth), math.cos(nadir)])
    C_in = dcm_ni(lat, lon, t, OMEGA_IE if omega_ie is None else omega_ie).T
    u = C_in @ u_n
    return float(u[0]), float(u[1]), float(u[2])


def spin_axes_for_site_deg(lat_deg: float, lon_deg: float, nadir_deg: Sequence[float],
                           azimuth_deg: Sequence[float], t: float = 0.0,
                           names: tuple[str, str] = ("nadir_deg", "azimuth_deg")) -> tuple[tuple, tuple]:
    """Inertial spin axes (u_a_i, u_b_i) of two gyros set at site (lat_deg, lon_deg) [deg] at
    time ``t`` [s] to nadir angles ``nadir_deg`` in (0, 180) and azimuths ``azimuth_deg``
    [deg] (each (gyro a, gyro b)): the degree-unit edge of :func:`spin_axis_for_site`.
    ``ValueError`` names the offending argument by ``names`` (e.g. a node's parameters)."""
    for name, values in zip(names, (nadir_deg, azimuth_deg)):
        if len(values) != 2 or not all(math.isfinite(x) for x in values):
            raise ValueError(f"parameter '{name}' needs two finite values (gyro a, gyro b), got {list(values)}")
    if not all(0.0 < x < 180.0 for x in nadir_deg):
        raise ValueError(f"parameter '{names[0]}' must be in (0, 180) deg, got {list(nadir_deg)}")
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    return tuple(spin_axis_for_site(lat, lon, t, math.radians(nd), math.radians(az))  # type: ignore[return-value]
                 for nd, az in zip(nadir_deg, azimuth_deg))


# --- position fix --------------------------------------------------------------------------
def _lat_lon_from_up(r: tuple[float, float, float], t: float, omega_ie: float) -> tuple[float, float]:
    rx, ry, rz = r
    lat = math.atan2(rz, math.hypot(rx, ry))
    lon = wrap_pi(math.atan2(ry, rx) - omega_ie * t)
    return lat, lon


def _up_candidates(
    u_a_i: Vector3,
    u_b_i: Vector3,
    theta_a: float,
    theta_b: float,
    tolerances: FixTolerances,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    ax, ay, az = unit_vector(u_a_i, "u_a_i")
    bx, by, bz = unit_vector(u_b_i, "u_b_i")
    theta_a = _check_nadir(theta_a, "theta_a")
    theta_b = _check_nadir(theta_b, "theta_b")
    g = ax * bx + ay * by + az * bz
    wx, wy, wz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    w2 = wx * wx + wy * wy + wz * wz
    sin_sep = math.sqrt(w2)
    if sin_sep < tolerances.min_sin_gyro_separation:
        raise ValueError(
            "gyro vectors u_a_i and u_b_i are parallel or antiparallel "
            f"(sin of their separation {sin_sep:.3g}): the nadir circles are concentric, no unique fix"
        )
    ca, cb = -math.cos(theta_a), -math.cos(theta_b)
    x = (ca - g * cb) / w2
    y = (cb - g * ca) / w2
    px, py, pz = x * ax + y * bx, x * ay + y * by, x * az + y * bz
    h2 = 1.0 - (px * px + py * py + pz * pz)
    # h2 * w2 = (r·w)² = (sin θa sin θb sin Δα)²: compare the crossing angle, not raw h2.
    crossing2 = h2 * w2
    limit2 = (math.sin(theta_a) * math.sin(theta_b) * tolerances.min_sin_crossing_angle) ** 2
    if crossing2 < -limit2:
        raise ValueError(
            "nadir circles do not intersect: nadir angles theta_a, theta_b are inconsistent "
            "with the angle between the gyro vectors"
        )
    if crossing2 <= limit2:
        raise ValueError(
            "nadir circles are tangent (crossing angle below min_sin_crossing_angle): "
            "the fix is not unique / ill-conditioned"
        )
    z = math.sqrt(h2 / w2)
    # r·w = −sin θa sin θb sin Δα, so the branch with sin Δα > 0 has the negative w component.
    first = (px - z * wx, py - z * wy, pz - z * wz)
    second = (px + z * wx, py + z * wy, pz + z * wz)
    return first, second


def position_fix_candidates(
    u_a_i: Vector3,
    u_b_i: Vector3,
    theta_a: float,
    theta_b: float,
    t: float,
    tolerances: FixTolerances = DEFAULT_TOLERANCES,
    omega_ie: float = OMEGA_IE,
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Both (lat, lon) [rad] solutions of eq. 1 for two gyros; lon in [−π, π).

    The first candidate is the one where gyro b lies clockwise (toward east) of gyro a,
    sin(α_b − α_a) > 0; the second is its mirror image. Raises ``ValueError`` naming the cause
    for parallel/antiparallel gyro vectors, non-intersecting circles (inconsistent nadir
    angles) and tangent circles (see :class:`FixTolerances`).
    """
    if not math.isfinite(t):
        raise ValueError(f"t must be finite, got {t!r}")
    first, second = _up_candidates(u_a_i, u_b_i, theta_a, theta_b, tolerances)
    return _lat_lon_from_up(first, t, omega_ie), _lat_lon_from_up(second, t, omega_ie)


def position_fix(
    u_a_i: Vector3,
    u_b_i: Vector3,
    theta_a: float,
    theta_b: float,
    t: float,
    *,
    prior: tuple[float, float] | None = None,
    azimuth_sense: float | None = None,
    tolerances: FixTolerances = DEFAULT_TOLERANCES,
    omega_ie: float = OMEGA_IE,
) -> tuple[float, float]:
    """Geodetic (lat, lon) [rad] from two gyro vectors and their nadir angles at time t [s].

    Exactly one disambiguation rule must be given:

    * ``prior=(lat0, lon0)`` [rad]: the candidate nearest (great-circle) the prior;
    * ``azimuth_sense``: sign of sin(α_b − α_a), the sense in which gyro b lies from gyro a in
      azimuth (positive: b clockwise/east of a). It equals the sign of sin(ζ_b − ζ_a) from the
      body-measured azimuths relative to the ship's head, so it needs no position or heading.

    Raises ``ValueError`` for degenerate geometry as :func:`position_fix_candidates` does.
    """
    if (prior is None) == (azimuth_sense is None):
        raise ValueError("position_fix needs exactly one of prior or azimuth_sense to pick the branch")
    if not math.isfinite(t):
        raise ValueError(f"t must be finite, got {t!r}")
    first, second = _up_candidates(u_a_i, u_b_i, theta_a, theta_b, tolerances)
    if azimuth_sense is not None:
        if not math.isfinite(azimuth_sense) or azimuth_sense == 0.0:
            raise ValueError(f"azimuth_sense must be a nonzero finite sign, got {azimuth_sense!r}")
        chosen = first if azimuth_sense > 0.0 else second
    else:
        lat0, lon0 = (float(v) for v in prior)  # type: ignore[union-attr]
        _check_lat_lon_t(lat0, lon0, t)
        big0 = lon0 + omega_ie * t
        c0 = math.cos(lat0)
        r0 = (c0 * math.cos(big0), c0 * math.sin(big0), math.sin(lat0))
        d1 = first[0] * r0[0] + first[1] * r0[1] + first[2] * r0[2]
        d2 = second[0] * r0[0] + second[1] * r0[1] + second[2] * r0[2]
        chosen = first if d1 >= d2 else second
    return _lat_lon_from_up(chosen, t, omega_ie)


# --- error model ---------------------------------------------------------------------------
def perturbation_matrix(
    u_a_i: Vector3, u_b_i: Vector3, lat: float, lon: float, t: float, omega_ie: float = OMEGA_IE
) -> np.ndarray:
    """W = ∂(θ_a, θ_b)/∂(lat, lon) [rad/rad], rows (cos α_k, cos φ sin α_k); shape (2, 2).

    Linearised measurement geometry of eq. 31 expressed in nadir angles (see module doc).
    Raises ``ValueError`` when a gyro vector is vertical (θ not differentiable there).
    """
    _check_lat_lon_t(lat, lon, t)
    cl = math.cos(lat)
    rows = []
    for u, name in ((u_a_i, "u_a_i"), (u_b_i, "u_b_i")):
        north, east, _ = _ned_components(unit_vector(u, name), lat, lon, t, omega_ie)
        s = math.hypot(north, east)
        if s < VERTICAL_SIN_TOL:
            raise ValueError(f"{name} is along the local vertical: its nadir angle is not differentiable")
        rows.append((north / s, cl * east / s))
    return np.array(rows)


@dataclass(frozen=True)
class FixGeometry:
    """Linearised two-gyro fix geometry at one position (eq. 31–38).

    Fields: ``lat`` [rad]; ``W`` (2, 2) = ∂(θa, θb)/∂(φ, λ); ``Q_latlon`` (2, 2) =
    (WᵀW)⁻¹ in (φ, λ) [rad²/rad²]; ``Q_arc`` (2, 2) the cofactor matrix in (north arc, east
    arc) = (δφ, cos φ δλ) [rad²/rad²]; ``fdop`` = √trace(Q_arc) = √2/|sin Δα| (the
    meaningful FDOP); ``fdop_latlon`` = √(q_φφ + q_λλ) (the paper's eq. 37 read literally).
    """

    lat: float
    W: np.ndarray
    Q_latlon: np.ndarray
    Q_arc: np.ndarray
    fdop: float
    fdop_latlon: float

    def __post_init__(self) -> None:
        for name in ("W", "Q_latlon", "Q_arc"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (2, 2):
                raise ValueError(f"{name} must have shape (2, 2), got {value.shape}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{name} contains NaN or inf")
        if not (math.isfinite(self.fdop) and self.fdop > 0.0):
            raise ValueError(f"fdop must be finite and > 0, got {self.fdop!r}")

    def covariance_latlon(self, sigma_theta: float) -> np.ndarray:
        """cov(δφ, δλ) [rad²] = σ² (WᵀW)⁻¹ for i.i.d. nadir-angle errors σ [rad]; (2, 2)."""
        return _check_sigma(sigma_theta) ** 2 * self.Q_latlon

    def covariance_ne_m(self, sigma_theta: float, h: float = 0.0) -> np.ndarray:
        """cov(north, east) [m²] at height h [m] for nadir-angle errors σ [rad]; (2, 2)."""
        sigma = _check_sigma(sigma_theta)
        scale = np.array([meridian_radius(self.lat) + h, prime_vertical_radius(self.lat) + h])
        return sigma**2 * self.Q_arc * np.outer(scale, scale)

    def position_error_m(self, sigma_theta: float, h: float = 0.0) -> float:
        """Horizontal position error (drms) [m] = FDOP σ scaled by the radii (eq. 38)."""
        return math.sqrt(float(np.trace(self.covariance_ne_m(sigma_theta, h))))


def _check_sigma(sigma_theta: float) -> float:
    sigma = float(sigma_theta)
    if not math.isfinite(sigma) or sigma < 0.0:
        raise ValueError(f"sigma_theta must be >= 0 rad, got {sigma_theta!r}")
    return sigma


def fix_geometry(
    u_a_i: Vector3,
    u_b_i: Vector3,
    lat: float,
    lon: float,
    t: float,
    tolerances: FixTolerances = DEFAULT_TOLERANCES,
    omega_ie: float = OMEGA_IE,
) -> FixGeometry:
    """Perturbation matrix, cofactor matrices and FDOP of the fix at (lat, lon, t).

    Raises ``ValueError`` when the circles are tangent (|sin Δα| below
    ``tolerances.min_sin_crossing_angle``) or at a pole (longitude undefined).
    """
    W = perturbation_matrix(u_a_i, u_b_i, lat, lon, t, omega_ie)
    cl = math.cos(lat)
    if abs(cl) < 1e-12:
        raise ValueError("fix_geometry: longitude is undefined at the poles")
    # Arc form: rows (cos α_k, sin α_k); det = sin(α_b − α_a).
    ca, sa = W[0, 0], W[0, 1] / cl
    cb, sb = W[1, 0], W[1, 1] / cl
    det = ca * sb - sa * cb
    if abs(det) < tolerances.min_sin_crossing_angle:
        raise ValueError(
            "nadir circles are tangent (crossing angle below min_sin_crossing_angle): "
            "the fix is not unique / ill-conditioned"
        )
    W_inv = np.array([[sb, -sa], [-cb, ca]]) / det
    Q_arc = W_inv @ W_inv.T
    scale = np.array([1.0, 1.0 / cl])
    Q_latlon = Q_arc * np.outer(scale, scale)
    return FixGeometry(
        lat=float(lat),
        W=W,
        Q_latlon=Q_latlon,
        Q_arc=Q_arc,
        fdop=math.sqrt(Q_arc[0, 0] + Q_arc[1, 1]),
        fdop_latlon=math.sqrt(Q_latlon[0, 0] + Q_latlon[1, 1]),
    )


# --- heading from earth rate ---------------------------------------------------------------
def _level(omega_b: tuple[float, float, float], roll: float, pitch: float) -> tuple[float, float, float]:
    """Body FRD vector resolved in the heading-only frame l: rot2(pitch)ᵀ rot1(roll)ᵀ v."""
    wx, wy, wz = omega_b
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    vy = cr * wy - sr * wz
    vz = sr * wy + cr * wz
    return cp * wx + sp * vz, vy, -sp * wx + cp * vz


def _vec3(v: Vector3, name: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(c) for c in v)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a 3-vector of floats") from exc
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f"{name} contains NaN or inf")
    return x, y, z


def heading_from_earth_rate(
    omega_ie_b: Vector3,
    roll: float = 0.0,
    pitch: float = 0.0,
    min_horizontal_rate: float = 1e-9,
) -> float:
    """Heading ψ [rad] in (−π, π], north toward east, from the earth rate sensed in the body.

    ``omega_ie_b``: earth rate in FRD body axes [rad/s], shape (3,) (vehicle and transport
    rates already removed); ``roll``, ``pitch``: 3-2-1 Euler angles [rad] used to level it.
    ψ = atan2(−ω_ly, ω_lx) (eq. 3–4 in FRD signs). Raises ``ValueError`` when the horizontal
    earth rate is below ``min_horizontal_rate`` [rad/s] (at the poles heading is unobservable).
    """
    lx, ly, _ = _level(_vec3(omega_ie_b, "omega_ie_b"), roll, pitch)
    if math.hypot(lx, ly) < min_horizontal_rate:
        raise ValueError(
            "heading_from_earth_rate: horizontal earth rate below min_horizontal_rate (at or near a pole)"
        )
    return math.atan2(-ly, lx)


def heading_error(
    omega_ie_b: Vector3,
    delta_omega_b: Vector3,
    roll: float = 0.0,
    pitch: float = 0.0,
    delta_roll: float = 0.0,
    delta_pitch: float = 0.0,
) -> float:
    """First-order heading error δψ [rad] of :func:`heading_from_earth_rate` (paper eq. 29).

    ``delta_omega_b`` (3,) [rad/s] is the error of the sensed body earth rate, ``delta_roll``
    and ``delta_pitch`` [rad] the errors of the levelling angles. In the levelled frame,
    δψ = (ω_ly δω_lx − ω_lx δω_ly)/(ω_lx² + ω_ly²), with
    δω_l = L(δω_b + δroll e1 × ω_b) + δpitch e2 × ω_l, L = rot2(pitch)ᵀ rot1(roll)ᵀ.
    """
    wx, wy, wz = _vec3(omega_ie_b, "omega_ie_b")
    dx, dy, dz = _vec3(delta_omega_b, "delta_omega_b")
    lx, ly, lz = _level((wx, wy, wz), roll, pitch)
    den = lx * lx + ly * ly
    if den == 0.0:
        raise ValueError("heading_error: horizontal earth rate is zero (heading unobservable)")
    # e1 × ω_b = (0, −ωz, ωy): a roll error rotates ω_b about the body x axis.
    ex, ey, _ = _level((dx, dy - delta_roll * wz, dz + delta_roll * wy), roll, pitch)
    # e2 × ω_l = (ω_lz, 0, −ω_lx): a pitch error rotates ω_l about the pitch axis.
    ex += delta_pitch * lz
    return (ly * ex - lx * ey) / den
