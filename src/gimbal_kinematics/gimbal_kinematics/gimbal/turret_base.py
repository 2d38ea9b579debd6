"""Base motion seen by the two-axis gimbal: the turret frame t's inertial motion.

The gimbal (outer frame a on joint ψm about t-z, inner frame m on θm about a-y) is carried
by the turret t (ψt about b-z, docs/spec.md §2). Everything the gimbal dynamics need from the host
is, resolved in t:

* ``ω_t``: inertial angular velocity of t [rad/s];
* ``α_t``: its time derivative (of the t-resolved components) [rad/s²];
* ``f_t = a_P − g``: inertial acceleration of the gimbal pivot P minus gravity [m/s²]
  (the "specific force" at P; −g for a pivot at rest).

Propagation b → t follows ``sighting_chain.chain_rates`` (the test checks this scalar form
against it): with u = rot3(ψt) ω_b,

    ω_t = u + ψ̇t e3,   α_t = rot3(ψt) α_b + ψ̈t e3 + u × (ψ̇t e3).

Gravity is plumb-bob (normal) gravity, which already contains the centripetal term of the
earth's rotation; the Coriolis term 2 ω_ie × v is zero because profiles do not translate.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from gimbal_kinematics.maths.attribute_views import vector_of
from gimbal_kinematics.maths.earth import earth_rate_n, normal_gravity

from .host_kernels import turret_base
from .host_state import HostState


class TurretBase(NamedTuple):
    """Turret inertial motion resolved in t: ω_t [rad/s], α_t [rad/s²], f_t = a_P − g [m/s²]."""

    wx: float
    wy: float
    wz: float
    ax: float
    ay: float
    az: float
    fx: float
    fy: float
    fz: float

    omega_t_t = vector_of("wx", "wy", "wz")
    alpha_t_t = vector_of("ax", "ay", "az")
    specific_force_t = vector_of("fx", "fy", "fz")


def rest_base(gravity_m_s2: float, roll: float = 0.0, pitch: float = 0.0, psi_t: float = 0.0) -> TurretBase:
    """Base at rest (no rotation, pivot not accelerating) with the host at (roll, pitch) [rad].

    The linearisation point of paper 1 §5 is ``rest_base(g)``: level host, turret at zero.
    """
    if not math.isfinite(gravity_m_s2) or gravity_m_s2 < 0.0:
        raise ValueError(f"gravity_m_s2 must be finite and >= 0, got {gravity_m_s2}")
    state = HostState(0.0, roll, pitch, 0.0, *([0.0] * 12), psi_t, 0.0, 0.0, 0.0, 0.0, 0.0)
    return turret_base_from_host(state, gravity_m_s2, (0.0, 0.0, 0.0))


def turret_base_from_host(
    state: HostState, gravity_m_s2: float, omega_in_n: tuple[float, float, float]
) -> TurretBase:
    """Turret base motion from a host sample [SI units].

    ``gravity_m_s2``: magnitude of normal gravity at the site (``earth.normal_gravity``);
    ``omega_in_n``: rate of NED relative to inertial space in n [rad/s] (earth rate, or
    zeros to treat n as inertial). The compiled :func:`.host_kernels.turret_base`.
    """
    x, y, z = omega_in_n
    return TurretBase(*turret_base(tuple(map(float, state)), float(gravity_m_s2), float(x), float(y), float(z)))


class SiteEnvironment(NamedTuple):
    """Gravity magnitude [m/s²] and NED rotation rate ω_in^n [rad/s] at a site."""

    gravity_m_s2: float
    omega_in_n: tuple[float, float, float]


def site_environment(lat_rad: float, height_m: float = 0.0, earth_rate: bool = True) -> SiteEnvironment:
    """Gravity and earth rate at a site; ``earth_rate=False`` treats n as inertial."""
    w = earth_rate_n(lat_rad) if earth_rate else np.zeros(3)
    return SiteEnvironment(normal_gravity(lat_rad, height_m), (float(w[0]), float(w[1]), float(w[2])))
