"""Geo-pointing: the line of sight from a vehicle to a geographic target, the paper 1
sighting-chain angles that put the LOS on it, and the 1σ pointing-error budget.

Positions are geodetic WGS-84 ``(lat, lon, h)``: latitude and longitude [rad], height above
the ellipsoid [m]. The LOS starts at the gimbal pivot P, which sits at the lever arm
``lever_arm_b`` [m] (body frame, from the INS reference point) from the vehicle position:
``r_P = r_v + C_en C_nb l_b``. The direction is the ECEF difference to the target resolved in
NED at the vehicle, ``u_n = C_en(vehicle)ᵀ (r_T − r_P) / |r_T − r_P|``: exact on the
ellipsoid, with no flat-earth or spherical step, at any range.

Inverse of the sighting chain (:mod:`.sighting_chain`, n → b → t → a → m, LOS = m-x). In the
body, the chain puts the LOS at ``(cos θm cos(ψt+ψm), cos θm sin(ψt+ψm), −sin θm)``, so only
the sum ψt + ψm is fixed by the LOS; the turret angle ψt is the caller's (measured) one, the
gimbal takes ψm = az_b − ψt and θm = el_b. θm is kept in [−90°, 90°]: the "over the top"
twin (ψm + 180°, 180° − θm) is never used, so the elevation limits must lie in that range.

At a limit (:class:`GimbalLimits`), every case is flagged so the caller can count it:

* elevation beyond its limits: θm stops at the limit; the LOS misses by the excess
  (``residual_rad``);
* gimbal azimuth beyond its limits, ``handover="stop"``: ψm stops at the nearer limit and
  the LOS misses; ``handover="turret"``: ψm stops at the limit and the turret takes the rest,
  ψt = az_b − ψm (the least turret motion that keeps the LOS exact);
* the LOS along the body z axis (el_b = ±90°, where the azimuth axes align and the azimuth
  is undefined): ψm holds the caller's ``psi_m_hold``, and the LOS is still exact if ±90° is
  inside the elevation limits.

Error budget: the pointing error is the angle between the LOS the chain realises with the
true attitude and the true LOS to the target, when the angles are computed from estimated
attitude and positions. To first order it is the vector d in the plane normal to the LOS

    d = ([u×] + P [L×] / R) J δe + P (δr_T − δr_P) / R,   P = I − u uᵀ,

with δe the (roll, pitch, heading) errors of the INS Euler angles, J the Jacobian from
Euler-angle errors to the attitude error rotation vector in n, L = C_nb l_b the lever arm in
n, R the range, δr_P and δr_T the vehicle and target position errors (each in its own NED,
σ_h per horizontal axis, σ_v vertical). The sources are independent, so the covariance of d
is a sum; each term of :class:`PointingBudget` is the RMS of |d| from one source alone, and
the total is their root-sum-square, the RMS of |d|. For a Gaussian d, the radius |d| stays
within at probability p (:func:`radial_quantile`; 95 %: ``PointingBudget.radius_95_rad``)
follows from the two semi-axes σ1 ≥ σ2 of its covariance: with d = (σ1 z1, σ2 z2) and z in
polar form (ρ² ~ χ²(2), θ uniform, independent),

    P(|d| ≤ r) = 1 − (1/2π) ∫ exp(−r² / (2 g(θ))) dθ,   g(θ) = σ1² cos²θ + σ2² sin²θ,

the Rayleigh σ √(−2 ln(1 − p)) (2.448 σ at 95 %) for σ1 = σ2, and the normal 1.960 σ1 for
σ2 = 0: for a two-axis error the RMS |d| is inside its own value only about 63 % of the time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from . import validate
from .earth import dcm_en, ecef_from_geodetic
from .free_gyro import wrap_pi
from .rotations import check_dcm, dcm_to_euler321, skew
from .sighting_chain import ELEVATION_SINGULAR_COS, dcm_bm

#: Default minimum range [m]: a target closer than this is taken for the vehicle itself (a
#: sight is about a metre across, so its LOS to such a point is not a pointing problem).
MIN_RANGE_M = 1.0
#: How the gimbal azimuth limit is handled (module docstring).
HANDOVER_CHOICES = ("stop", "turret")


def _wrap(angle: float, centre: float = 0.0) -> float:
    """``angle`` [rad] wrapped into [centre − π, centre + π)."""
    return centre + wrap_pi(angle - centre)


def check_geodetic(name: str, llh) -> tuple[float, float, float]:
    """``(lat, lon, h)`` [rad, rad, m] as floats; ``ValueError`` naming ``name`` when a value
    is not finite, the latitude is outside ±90° or the longitude outside ±360°."""
    try:
        lat, lon, h = (float(v) for v in llh)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (lat, lon, h), got {llh!r}") from None
    if not all(math.isfinite(v) for v in (lat, lon, h)):
        raise ValueError(f"{name}: position must be finite, got lat {math.degrees(lat):g}°, "
                         f"lon {math.degrees(lon):g}°, h {h:g} m")
    if abs(lat) > math.pi / 2:
        raise ValueError(f"{name}: latitude {math.degrees(lat):g}° is outside [-90°, 90°]")
    if abs(lon) > 2.0 * math.pi:
        raise ValueError(f"{name}: longitude {math.degrees(lon):g}° is outside [-360°, 360°]")
    return lat, lon, h


def _vector3(name: str, vec) -> np.ndarray:
    v = np.asarray(vec, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {vec!r}")
    return v


@dataclass(frozen=True)
class TargetLos:
    """The LOS from the sight pivot to the target: unit vector in NED at the vehicle (3,),
    range [m], azimuth from north towards east in (−π, π] and elevation above the local
    horizontal [rad]."""

    los_n: np.ndarray
    range_m: float
    azimuth_rad: float
    elevation_rad: float


def los_to_target(
    vehicle_llh, target_llh, C_nb: np.ndarray | None = None, lever_arm_b=(0.0, 0.0, 0.0),
    min_range_m: float = MIN_RANGE_M,
) -> TargetLos:
    """LOS from the sight pivot (vehicle position + ``C_nb @ lever_arm_b``) to the target.

    ``C_nb`` is needed only for a non-zero lever arm. Raises ``ValueError`` for a non-finite
    or out-of-range position, and for a target nearer than ``min_range_m`` [m].
    """
    lat, lon, h = check_geodetic("vehicle", vehicle_llh)
    target = check_geodetic("target", target_llh)
    lever_b = _vector3("lever_arm_b", lever_arm_b)
    C_ne = dcm_en(lat, lon).T
    d_n = C_ne @ (ecef_from_geodetic(*target) - ecef_from_geodetic(lat, lon, h))
    if np.any(lever_b):
        if C_nb is None:
            raise ValueError("los_to_target: a non-zero lever_arm_b needs C_nb")
        d_n = d_n - check_dcm(C_nb, "C_nb") @ lever_b
    rng = float(np.linalg.norm(d_n))
    if not rng >= min_range_m:
        raise ValueError(
            f"target is {rng:.3g} m from the sight, below the minimum range {min_range_m:g} m "
            "(a target at the vehicle's own position has no direction)")
    u = d_n / rng
    return TargetLos(u, rng, math.atan2(u[1], u[0]), math.atan2(-u[2], math.hypot(u[0], u[1])))


@dataclass(frozen=True)
class GimbalLimits:
    """Joint limits of the two-axis gimbal [rad] and the azimuth-limit policy.

    ``azimuth_*``: gimbal azimuth ψm relative to the turret; a span of 2π or more is a
    continuous (slip-ring) axis with no limit. ``elevation_*``: θm, within [−π/2, π/2].
    ``handover``: ``"stop"`` or ``"turret"`` (module docstring). The defaults limit nothing.
    """

    azimuth_min_rad: float = -math.pi
    azimuth_max_rad: float = math.pi
    elevation_min_rad: float = -math.pi / 2
    elevation_max_rad: float = math.pi / 2
    handover: str = "stop"

    def __post_init__(self) -> None:
        for name in ("azimuth_min_rad", "azimuth_max_rad", "elevation_min_rad", "elevation_max_rad"):
            validate.finite(name, getattr(self, name))
        if not self.azimuth_min_rad < self.azimuth_max_rad:
            raise ValueError(f"azimuth limits must have min < max, got [{self.azimuth_min_rad}, "
                             f"{self.azimuth_max_rad}] rad")
        if not -math.pi / 2 <= self.elevation_min_rad < self.elevation_max_rad <= math.pi / 2:
            raise ValueError(f"elevation limits must satisfy -π/2 <= min < max <= π/2, got "
                             f"[{self.elevation_min_rad}, {self.elevation_max_rad}] rad")
        if self.handover not in HANDOVER_CHOICES:
            raise ValueError(f"handover must be one of {HANDOVER_CHOICES}, got {self.handover!r}")

    @property
    def azimuth_continuous(self) -> bool:
        return self.azimuth_max_rad - self.azimuth_min_rad >= 2.0 * math.pi


@dataclass(frozen=True)
class JointSolution:
    """Joint angles (ψt, ψm, θm) [rad] that point the chain's LOS (m-x) along a direction,
    the flags of what happened at the limits, and ``residual_rad``: the angle between the
    LOS these angles give and the direction asked for (0 unless a limit stopped it)."""

    psi_t: float
    psi_m: float
    theta_m: float
    azimuth_limited: bool
    elevation_limited: bool
    turret_handover: bool
    singular: bool
    residual_rad: float


def _clip_azimuth(psi_m: float, limits: GimbalLimits) -> tuple[float, bool]:
    """ψm wrapped around the middle of its range and clipped to the nearer limit."""
    if limits.azimuth_continuous:
        return _wrap(psi_m), False
    lo, hi = limits.azimuth_min_rad, limits.azimuth_max_rad
    psi_m = _wrap(psi_m, 0.5 * (lo + hi))
    clipped = min(max(psi_m, lo), hi)
    return clipped, clipped != psi_m


def joint_angles_for_los(
    C_nb: np.ndarray, los_n, psi_t: float, limits: GimbalLimits = GimbalLimits(),
    psi_m_hold: float = 0.0,
) -> JointSolution:
    """Inverse of the sighting chain: (ψt, ψm, θm) that point m-x along ``los_n`` (NED,
    normalised here), given the host attitude ``C_nb`` and the turret angle ``psi_t``
    [rad]. ``psi_m_hold``: the gimbal azimuth kept at the singularity (el_b = ±90°).
    Limits and flags as in the module docstring."""
    C_nb = check_dcm(C_nb, "C_nb")
    u_n = _vector3("los_n", los_n)
    norm = float(np.linalg.norm(u_n))
    if norm < 1e-12:
        raise ValueError("los_n: direction is zero")
    psi_t = validate.finite("psi_t", float(psi_t))
    psi_m_hold = validate.finite("psi_m_hold", float(psi_m_hold))
    u_b = C_nb.T @ (u_n / norm)
    horiz = math.hypot(u_b[0], u_b[1])
    el_b = math.atan2(-u_b[2], horiz)
    singular = horiz < ELEVATION_SINGULAR_COS
    theta_m = min(max(el_b, limits.elevation_min_rad), limits.elevation_max_rad)
    psi_m = psi_m_hold if singular else _wrap(math.atan2(u_b[1], u_b[0]) - psi_t)
    psi_m, az_limited = _clip_azimuth(psi_m, limits)
    handover = az_limited and not singular and limits.handover == "turret"
    if handover:
        psi_t = _wrap(math.atan2(u_b[1], u_b[0]) - psi_m)
    achieved = dcm_bm(psi_t, psi_m, theta_m)[:, 0]
    residual = math.atan2(float(np.linalg.norm(np.cross(achieved, u_b))), float(achieved @ u_b))
    return JointSolution(psi_t, psi_m, theta_m, az_limited, theta_m != el_b, handover, singular, residual)


def geo_point(
    vehicle_llh, C_nb: np.ndarray, target_llh, psi_t: float, limits: GimbalLimits = GimbalLimits(),
    lever_arm_b=(0.0, 0.0, 0.0), psi_m_hold: float = 0.0, min_range_m: float = MIN_RANGE_M,
) -> tuple[TargetLos, JointSolution]:
    """The LOS to a geodetic target and the joint angles that point the sight along it
    (:func:`los_to_target` then :func:`joint_angles_for_los`)."""
    los = los_to_target(vehicle_llh, target_llh, C_nb, lever_arm_b, min_range_m)
    return los, joint_angles_for_los(C_nb, los.los_n, psi_t, limits, psi_m_hold)


@dataclass(frozen=True)
class PointingSigmas:
    """1σ errors of the inputs: INS roll, pitch, heading (Euler-angle errors) [rad];
    vehicle and target position per horizontal axis (north, east) and vertical [m]."""

    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    heading_rad: float = 0.0
    vehicle_horizontal_m: float = 0.0
    vehicle_vertical_m: float = 0.0
    target_horizontal_m: float = 0.0
    target_vertical_m: float = 0.0

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            validate.nonneg_finite(name, getattr(self, name))


#: The budget's terms, in the order a report lists them.
BUDGET_TERMS = ("roll", "pitch", "heading", "vehicle_horizontal", "vehicle_vertical",
                "target_horizontal", "target_vertical")


@dataclass(frozen=True)
class PointingBudget:
    """Predicted pointing error: ``terms`` maps each of :data:`BUDGET_TERMS` to the RMS
    angle [rad] that source alone causes; ``total_rad`` is their root-sum-square (the RMS
    of the error angle); ``covariance_n`` (3, 3) the covariance of the error vector d in
    NED (rank 2, in the plane normal to the LOS); ``principal_sigmas_rad`` its two 1σ
    semi-axes, largest first; ``range_m`` the range it was computed for."""

    terms: dict[str, float]
    total_rad: float
    covariance_n: np.ndarray
    principal_sigmas_rad: tuple[float, float]
    range_m: float

    @property
    def radius_95_rad(self) -> float:
        """The radius the error angle stays within 95 % of the time [rad]
        (:func:`radial_quantile` of the two semi-axes)."""
        return radial_quantile(*self.principal_sigmas_rad)


#: midpoints over a quarter period of the π-periodic, even integrand of P(|d| ≤ r): the
#: midpoint rule on a periodic integrand converges geometrically (1e-15 at 256 nodes here)
_THETA = (np.arange(256) + 0.5) * (0.5 * math.pi / 256)


def radial_quantile(sigma_major: float, sigma_minor: float, p: float = 0.95) -> float:
    """The radius [same unit as the σ] a 2-D Gaussian error of semi-axes σ1 ≥ σ2 stays within
    at probability ``p`` (module docstring): the root of P(|d| ≤ r) = p by Newton's method,
    kept inside its bracket [σ1 √χ²₁(p), σ1 √χ²₂(p)] (|d| ≥ σ1 |z1| and |d| ≤ σ1 ρ)."""
    validate.nonneg_finite("sigma_major", sigma_major)
    validate.nonneg_finite("sigma_minor", sigma_minor)
    s1, s2 = max(sigma_major, sigma_minor), min(sigma_major, sigma_minor)
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p!r}")
    if s1 == 0.0:
        return 0.0
    g = (s1 * np.cos(_THETA)) ** 2 + (s2 * np.sin(_THETA)) ** 2
    lo, hi = s1 * NormalDist().inv_cdf(0.5 + 0.5 * p), s1 * math.sqrt(-2.0 * math.log1p(-p))
    r = 0.5 * (lo + hi)
    for _ in range(60):
        e = np.exp(-r * r / (2.0 * g))
        f = 1.0 - float(np.mean(e)) - p
        if f > 0.0:
            hi = r
        else:
            lo = r
        slope = float(np.mean(r / g * e))
        step = r - f / slope if slope > 0.0 else 0.5 * (lo + hi)
        r_next = step if lo < step < hi else 0.5 * (lo + hi)
        if abs(r_next - r) <= 1e-14 * r:
            return r_next
        r = r_next
    return r


def euler_error_jacobian(C_nb: np.ndarray) -> np.ndarray:
    """J (3, 3): attitude error rotation vector in n per (roll, pitch, heading) error [rad].

    With C_nb = Rz(ψ) Ry(θ) Rx(φ), a change δψ turns about n-z, δθ about the once-yawed y
    axis Rz(ψ) e2, δφ about the body x axis C_nb e1, so C(e + δe) C(e)ᵀ ≈ I + [(J δe)×].
    Raises ``ValueError`` at pitch ±90°, where Euler angles (and their errors) are undefined.
    """
    _, _, yaw = dcm_to_euler321(C_nb)
    return np.column_stack((np.asarray(C_nb, dtype=float)[:, 0],
                            [-math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]))


def _rotated_cov(C_ab: np.ndarray, sigma_h: float, sigma_v: float) -> np.ndarray:
    return C_ab @ np.diag([sigma_h**2, sigma_h**2, sigma_v**2]) @ C_ab.T


def pointing_budget(
    vehicle_llh, C_nb: np.ndarray, target_llh, sigmas: PointingSigmas,
    lever_arm_b=(0.0, 0.0, 0.0), min_range_m: float = MIN_RANGE_M,
) -> PointingBudget:
    """1σ pointing-error budget of the geo-pointing geometry (module docstring)."""
    validate.of_type("sigmas", sigmas, PointingSigmas)
    los = los_to_target(vehicle_llh, target_llh, C_nb, lever_arm_b, min_range_m)
    C_nb = check_dcm(C_nb, "C_nb")
    u, R = los.los_n, los.range_m
    proj = np.eye(3) - np.outer(u, u)
    lever_n = C_nb @ _vector3("lever_arm_b", lever_arm_b)
    A_e = (skew(u) + proj @ skew(lever_n) / R) @ euler_error_jacobian(C_nb)
    # the target's NED axes differ from the vehicle's by the angle between their verticals
    lat_v, lon_v, _ = check_geodetic("vehicle", vehicle_llh)
    lat_t, lon_t, _ = check_geodetic("target", target_llh)
    C_nv_nt = dcm_en(lat_v, lon_v).T @ dcm_en(lat_t, lon_t)
    s = sigmas
    covs = {
        "roll": s.roll_rad**2 * np.outer(A_e[:, 0], A_e[:, 0]),
        "pitch": s.pitch_rad**2 * np.outer(A_e[:, 1], A_e[:, 1]),
        "heading": s.heading_rad**2 * np.outer(A_e[:, 2], A_e[:, 2]),
        "vehicle_horizontal": proj @ _rotated_cov(np.eye(3), s.vehicle_horizontal_m, 0.0) @ proj / R**2,
        "vehicle_vertical": proj @ _rotated_cov(np.eye(3), 0.0, s.vehicle_vertical_m) @ proj / R**2,
        "target_horizontal": proj @ _rotated_cov(C_nv_nt, s.target_horizontal_m, 0.0) @ proj / R**2,
        "target_vertical": proj @ _rotated_cov(C_nv_nt, 0.0, s.target_vertical_m) @ proj / R**2,
    }
    cov = sum(covs.values())
    eig = np.sort(np.linalg.eigvalsh(cov))[::-1]
    terms = {name: math.sqrt(max(float(np.trace(c)), 0.0)) for name, c in covs.items()}
    return PointingBudget(terms, math.sqrt(max(float(np.trace(cov)), 0.0)), cov,
                          (math.sqrt(max(eig[0], 0.0)), math.sqrt(max(eig[1], 0.0))), R)
