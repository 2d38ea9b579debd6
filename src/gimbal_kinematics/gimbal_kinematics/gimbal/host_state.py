"""Host-vehicle motion sample: exact attitude, body rates and accelerations at one instant.

A motion profile (:mod:`.motion_profiles`) returns a :class:`HostState`: the 3-2-1 Euler
angles (φ, θ, ψ) of the host body ``b`` relative to the navigation frame ``n`` (NED) and
their first two time derivatives, the body rate ``ω_nb^b`` and body angular acceleration
``α_nb^b`` derived from them analytically, the turret angle ψt (about b-z) with its rate
and acceleration, and the linear acceleration of the gimbal pivot relative to the earth,
resolved in b.

Body rates from Euler rates (ω = E(φ, θ) ė)::

    p = φ̇ − sθ ψ̇
    q = cφ θ̇ + sφ cθ ψ̇
    r = −sφ θ̇ + cφ cθ ψ̇

and α = dω/dt, which keeps the Ė ė term (product rule on every sine and cosine).

The gimbal dynamics need *inertial* rates. With ``ω_in^n`` the rotation rate of n relative
to inertial space (earth rate at the site; the profiles do not translate, so transport
rate is zero) held constant in n::

    ω_ib^b = ω_nb^b + C_bn ω_in^n
    α_ib^b = α_nb^b − ω_nb^b × (C_bn ω_in^n)

The second line follows from Ċ_bn = −[ω_nb^b ×] C_bn. α is the time derivative of the
b-resolved components, which equals the inertial derivative resolved in b because
ω × ω = 0. :func:`body_inertial_rates` is the single place where this conversion is done.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from gimbal_kinematics.maths.attribute_views import vector_of

from .host_kernels import host_fields, inertial_rates


class HostState(NamedTuple):
    """Exact host motion at time ``t`` [s]; every field is a float.

    Angles [rad], rates [rad/s], accelerations [rad/s²]; ``p, q, r`` is ω_nb^b and
    ``p_dot, q_dot, r_dot`` is α_nb^b (host relative to NED, resolved in b);
    ``accel_x, accel_y, accel_z`` is the gimbal pivot's acceleration relative to the
    earth, resolved in b [m/s²] (gravity not included).
    """

    t: float
    roll: float
    pitch: float
    yaw: float
    roll_dot: float
    pitch_dot: float
    yaw_dot: float
    roll_ddot: float
    pitch_ddot: float
    yaw_ddot: float
    p: float
    q: float
    r: float
    p_dot: float
    q_dot: float
    r_dot: float
    psi_t: float
    psi_t_dot: float
    psi_t_ddot: float
    accel_x: float
    accel_y: float
    accel_z: float

    euler = vector_of("roll", "pitch", "yaw", doc="(φ, θ, ψ) [rad]; shape (3,).")
    euler_rates = vector_of("roll_dot", "pitch_dot", "yaw_dot", doc="(φ̇, θ̇, ψ̇) [rad/s]; shape (3,).")
    omega_nb_b = vector_of("p", "q", "r", doc="Body rate relative to NED, resolved in b [rad/s]; shape (3,).")
    alpha_nb_b = vector_of("p_dot", "q_dot", "r_dot",
                           doc="Body angular acceleration relative to NED, resolved in b [rad/s²]; shape (3,).")
    accel_b = vector_of("accel_x", "accel_y", "accel_z",
                        doc="Pivot acceleration relative to the earth, resolved in b [m/s²]; shape (3,).")


def host_state_from_euler(
    t: float,
    euler: tuple[float, float, float],
    euler_dot: tuple[float, float, float],
    euler_ddot: tuple[float, float, float],
    turret: tuple[float, float, float] = (0.0, 0.0, 0.0),
    accel_b: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> HostState:
    """Build a :class:`HostState` from Euler angles and their derivatives [rad, rad/s, rad/s²].

    ``turret`` is (ψt, ψ̇t, ψ̈t); ``accel_b`` the pivot acceleration in b [m/s²].
    Body rates and accelerations follow the module docstring.
    """
    return HostState(*host_fields(
        float(t), float(euler[0]), float(euler[1]), float(euler[2]), float(euler_dot[0]), float(euler_dot[1]),
        float(euler_dot[2]), float(euler_ddot[0]), float(euler_ddot[1]), float(euler_ddot[2]), float(turret[0]),
        float(turret[1]), float(turret[2]), float(accel_b[0]), float(accel_b[1]), float(accel_b[2])))


def inertial_rates_scalar(
    state: HostState, omega_in_n: tuple[float, float, float]
) -> tuple[float, float, float, float, float, float]:
    """(ω_ib^b, α_ib^b) as six floats [rad/s, rad/s²]; the hot-path form of
    :func:`body_inertial_rates` (module docstring for the equations)."""
    p, q, r = state.p, state.q, state.r
    if omega_in_n[0] == 0.0 and omega_in_n[1] == 0.0 and omega_in_n[2] == 0.0:
        return p, q, r, state.p_dot, state.q_dot, state.r_dot
    return inertial_rates_trig(state, omega_in_n, math.cos(state.roll), math.sin(state.roll),
                               math.cos(state.pitch), math.sin(state.pitch))


def inertial_rates_trig(
    state: HostState, omega_in_n: tuple[float, float, float], cf: float, sf: float, ct: float, st: float
) -> tuple[float, float, float, float, float, float]:
    """:func:`inertial_rates_scalar` for a caller that already has cos, sin of roll and pitch
    (the compiled :func:`.host_kernels.inertial_rates`)."""
    x, y, z = omega_in_n
    return inertial_rates(state.p, state.q, state.r, state.p_dot, state.q_dot, state.r_dot, state.yaw,
                          float(x), float(y), float(z), cf, sf, ct, st)


def body_inertial_rates(state: HostState, omega_in_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Host inertial rate ω_ib^b [rad/s] and acceleration α_ib^b [rad/s²], each shape (3,).

    ``omega_in_n``: rotation rate of NED relative to inertial space, resolved in n [rad/s],
    shape (3,), assumed constant (``earth.earth_rate_n(lat)`` for a host that does not
    translate). Pass zeros to treat n as inertial, as paper 1 does in its rate equations.
    """
    w = np.asarray(omega_in_n, dtype=float)
    if w.shape != (3,):
        raise ValueError(f"omega_in_n: expected shape (3,), got {w.shape}")
    v = inertial_rates_scalar(state, (float(w[0]), float(w[1]), float(w[2])))
    return np.array(v[:3]), np.array(v[3:])
