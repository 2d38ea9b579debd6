"""Four-gimbal inertially stabilized platform of paper 3 (docs/spec.md §3.3): geometry and servo signals.

Frames and joints (outer to inner; the paper lists the gimbals inner to outer a, q, p, r)::

    b  base = vehicle body, FRD
    r  outer-roll gimbal   C_rb = rot1(θ_r)   (about b-x, the vehicle roll axis)
    p  pitch gimbal        C_pr = rot2(θ_p)   (about r-y)
    q  inner-roll gimbal   C_qp = rot1(θ_q)   (about p-x)
    s  azimuth gimbal      C_sq = rot3(θ_a)   (about q-z) = the platform / stable element

``rot_i`` are the frame rotations of :mod:`.rotations`; a gimbal angle is the rotation of the
inner member relative to the outer one, as the resolvers read it. All angles zero puts every
frame on the base axes. The platform frame is called ``s`` (the paper's p-frame, and its
s-frame of section 2.2) because ``p`` names the pitch gimbal, and the paper's local geographic
frame "t" (ENU) is this library's NED frame ``n`` (``t`` is the turret in ``sighting_chain``).
A platform held level and turned by the modulation angle φz about the local vertical has

    C_sn = rot3(φz),   φz about NED *down* (positive clockwise seen from above),

so the paper's φz, measured about ENU up, is -φz here. ``C_ENU_NED`` converts vectors.

Angle and rate vectors are shape (4,) in the paper's order (a, q, p, r) = (θ_a, θ_q, θ_p, θ_r).
Units: rad, rad/s, rad/s².

Derivation summary
------------------
Rates. For a child frame c turned by δ about its unit axis u relative to its parent
(``C_cp = rot_u(δ)``), ω_c = C_cp ω_p + δ̇ u and α_c = C_cp α_p + δ̈ u + (C_cp ω_p) × (δ̇ u),
as in ``sighting_chain``. Chaining b → r → p → q → s gives the platform inertial rate ω_s.

Joint axes, resolved in the pitch-gimbal frame p (used by every inverse below)::

    outer roll  C_pr e1 = ( cos θ_p, 0, sin θ_p)
    pitch       e2
    inner roll  e1
    azimuth     C_pq e3 = ( 0, -sin θ_q, cos θ_q)

At θ_q = 0 the azimuth, inner-roll and pitch axes are mutually orthogonal; the outer roll
aligns with the azimuth axis at θ_p = ±90° (gimbal lock), and the azimuth aligns with the
pitch axis at θ_q = ±90°.

Control signals, paper eq. 1. The gyro pickoffs give the small rotation δ of the platform away
from its gyro reference, resolved in s. To first order the inner three gimbals realise
δ = δθ_a e3 + C_sq δθ_q e1 + C_sp δθ_p e2 (the outer roll is not driven by the pickoffs).
Resolving in q with v = C_qs δ (C_qs = rot3(θ_a)ᵀ) and C_qp e2 = (0, cos θ_q, -sin θ_q)::

    δθ_q = v1,   δθ_p = v2 / cos θ_q,   δθ_a = v3 + v2 tan θ_q

At inner-roll null (θ_q = 0) this is exactly the paper's rotation through θ_a,
[δθ_q, δθ_p, δθ_a] = [[cos θa, -sin θa, 0], [sin θa, cos θa, 0], [0, 0, 1]] δ; the paper orders
the rows (pitch, inner roll, azimuth) because its platform x axis is the pitch axis, and calls
the matrix C_t^p although it is the azimuth-gimbal rotation C_qs. These δθ are the amounts by
which each gimbal angle exceeds the value that would put the platform back on its reference;
each loop drives its gimbal by -δθ (sign in the controller).

Outer-roll null, paper eq. 1. With the platform held by the inner loops and the base still,
an outer-roll increment δθ_r is absorbed by the inner gimbals: from the axis table,
δθ_q = -cos θ_p δθ_r and δθ_a = -sin θ_p δθ_r (at θ_q = 0). Driving the outer roll by
Δθ_rm = θ_q sec θ_p therefore returns the inner roll to null, which keeps the inner three
axes orthogonal. The gain sec θ_p is unbounded at pitch gimbal lock.

Command rate, paper eqs. 2-4. A platform that stays level at modulation angle φz has
ω_is^s = C_sn (ω_ie^n + ω_en^n) + φ̇z e3 = rot3(φz) ω_in^n + φ̇z e3 (e3 is the rotation axis,
so C_sn e3 = e3). In ENU this is the paper's ω_it^t = (-V_N/R_M, Ω cos L + V_E/R_N,
Ω sin L + V_E tan L / R_N) plus ω_r about up. The gyro torquing command subtracts the estimated
gyro drift so that the drifting gyro reference moves at exactly ω_c.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np

from . import platform_kernels as fk
from .platform_kernels import inner_signals
from .earth import earth_rate_n, transport_rate_n
from .rotations import dcm_to_euler321, rot1, rot2, rot3, rotation_vector_from_dcm

#: Order of the (4,) angle/rate vectors: azimuth a, inner roll q, pitch p, outer roll r
#: (the paper's inner-to-outer order).
GIMBAL_ORDER = ("a", "q", "p", "r")

#: Gimbal-lock margin [rad]: servo-facing functions raise ``ValueError`` when the pitch gimbal
#: (for the outer-roll null and the inner-roll-held inverse) or the inner-roll gimbal (for the
#: pickoff resolution and the rate inverses) is within this angle of ±90°. There the outer-roll
#: loop gain sec θ_p (or the azimuth gain sec θ_q) exceeds 1/sin(1°) ≈ 57 times its nominal
#: value: a 1″ inner-roll error would command ~1′ of outer roll, beyond any sensible servo.
GIMBAL_LOCK_MARGIN = math.radians(1.0)
_LOCK_COS = math.sin(GIMBAL_LOCK_MARGIN)

#: |cos| below which angle decomposition fails outright (axes numerically aligned).
_DECOMPOSE_COS_TOL = 1e-9

#: Vector conversion between NED and ENU: ``vec_enu = C_ENU_NED @ vec_ned``. It is symmetric
#: and its own inverse.
C_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
C_ENU_NED.flags.writeable = False

#: Paper 3's modulation rate [deg/s].
PAPER_ROTATION_RATE_DEG_S = 1.2


# --------------------------------------------------------------------------------------------
# small scalar helpers (the servo loop calls these per step; plain floats avoid numpy overhead)

def _unpack(vec: Sequence[float], n: int, name: str) -> list[float]:
    # ndarray.tolist() yields Python floats, whose arithmetic is several times faster than
    # numpy scalars in the scalar closed forms below
    if isinstance(vec, np.ndarray):
        if vec.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {vec.shape}")
        return vec.tolist()
    try:
        vals = [float(x) for x in vec]
    except TypeError as exc:
        raise ValueError(f"{name} must be a sequence of {n} floats, got {vec!r}") from exc
    if len(vals) != n:
        raise ValueError(f"{name} must have shape ({n},), got {len(vals)} elements")
    return vals


def _r1(c: float, s: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return x, c * y + s * z, -s * y + c * z


def _r2(c: float, s: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return c * x - s * z, y, s * x + c * z


def _r3(c: float, s: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return c * x + s * y, -s * x + c * y, z


def _lock_check(cos_val: float, angle: float, gimbal: str, consequence: str) -> None:
    if abs(cos_val) < _LOCK_COS:
        raise ValueError(
            f"gimbal lock: {gimbal} angle {math.degrees(math.remainder(angle, math.tau)):.4f}° is within "
            f"{math.degrees(GIMBAL_LOCK_MARGIN):g}° of ±90° ({consequence})"
        )


# --------------------------------------------------------------------------------------------
# DCMs

def dcm_br(theta_r: float) -> np.ndarray:
    """``C_br``: outer-roll gimbal to base, θ_r [rad] about b-x; shape (3, 3)."""
    return rot1(theta_r).T


def dcm_rp(theta_p: float) -> np.ndarray:
    """``C_rp``: pitch gimbal to outer-roll gimbal, θ_p [rad] about r-y; shape (3, 3)."""
    return rot2(theta_p).T


def dcm_pq(theta_q: float) -> np.ndarray:
    """``C_pq``: inner-roll gimbal to pitch gimbal, θ_q [rad] about p-x; shape (3, 3)."""
    return rot1(theta_q).T


def dcm_qs(theta_a: float) -> np.ndarray:
    """``C_qs``: platform to inner-roll gimbal, θ_a [rad] about q-z; shape (3, 3).

    This is paper 3's eq. 1 matrix [[cos θa, -sin θa, 0], [sin θa, cos θa, 0], [0, 0, 1]]
    that resolves the platform pickoffs onto the inner-roll and pitch axes.
    """
    return rot3(theta_a).T


def dcm_bs(angles: Sequence[float]) -> np.ndarray:
    """``C_bs``: platform (stable element) to base; ``angles`` = (θ_a, θ_q, θ_p, θ_r) [rad].

    Closed form of ``dcm_br(θ_r) @ dcm_rp(θ_p) @ dcm_pq(θ_q) @ dcm_qs(θ_a)``; shape (3, 3).
    """
    return fk.dcm_bs(*_unpack(angles, 4, "angles"))


def dcm_sb(angles: Sequence[float]) -> np.ndarray:
    """``C_sb``: base to platform; ``angles`` = (θ_a, θ_q, θ_p, θ_r) [rad]; shape (3, 3)."""
    return dcm_bs(angles).T


def dcm_ns_level(phi_z: float) -> np.ndarray:
    """``C_ns`` of a level platform turned by φz [rad] about NED down; shape (3, 3)."""
    return rot3(phi_z).T


def platform_misalignment_enu(C_ns: np.ndarray, phi_z: float) -> np.ndarray:
    """Misalignment (δφE, δφN, δφU) [rad] of the platform ``C_ns`` (3, 3) from the level frame
    turned by ``phi_z`` [rad] about NED down (where it is believed to be); shape (3,).

    The rotation vector φ with ``C_ns = exp([φ×]) dcm_ns_level(φz)`` (it takes the believed
    frame to the true one), in paper 3's ENU component order; δφU > 0 is a counter-clockwise
    (seen from above) azimuth error.
    """
    v = rotation_vector_from_dcm(np.asarray(C_ns, dtype=float) @ rot3(phi_z))
    return np.array([v[1], v[0], -v[2]])


def gimbal_angles_from_dcm(C_sb: np.ndarray, theta_r: float | None = None) -> np.ndarray:
    """Gimbal angles (θ_a, θ_q, θ_p, θ_r) [rad] that realise ``C_sb`` (base to platform).

    The four-gimbal chain is redundant. With ``theta_r=None`` the outer roll is chosen so the
    inner roll sits at null (θ_q = 0), the state the outer-roll loop maintains; the remaining
    angles are then a 3-2-1 decomposition. With ``theta_r`` given, the other three follow from
    C_sb rot1(θ_r)ᵀ = rot3(θ_a) rot1(θ_q) rot2(θ_p), with θ_q in [-π/2, π/2]. Returns shape (4,).

    Raises ``ValueError`` when the decomposition is singular: θ_p = ±90° for the null
    solution, θ_q = ±90° otherwise.
    """
    C_sb = np.asarray(C_sb, dtype=float)
    if theta_r is None:
        if abs(C_sb[2, 0]) > 1.0 - _DECOMPOSE_COS_TOL:
            raise ValueError(
                "gimbal_angles_from_dcm: gimbal lock, the pitch gimbal would be at ±90° with "
                "the inner roll at null (outer-roll and azimuth axes aligned)"
            )
        phi, theta, psi = dcm_to_euler321(C_sb)
        return np.array([-psi, 0.0, -theta, -phi])
    M = C_sb @ rot1(theta_r).T
    sq = -M[2, 1]
    if abs(sq) > 1.0 - _DECOMPOSE_COS_TOL:
        raise ValueError(
            "gimbal_angles_from_dcm: gimbal lock, the inner-roll gimbal would be at ±90° "
            "(azimuth and pitch axes aligned)"
        )
    q = math.asin(max(-1.0, min(1.0, sq)))
    p = math.atan2(M[2, 0], M[2, 2])
    a = math.atan2(M[0, 1], M[1, 1])
    return np.array([a, q, p, float(theta_r)])


# --------------------------------------------------------------------------------------------
# angular velocity and acceleration

@dataclass(frozen=True)
class FourGimbalRates:
    """Inertial angular velocity [rad/s] and acceleration [rad/s²] of each gimbal frame,
    resolved in its own frame; each shape (3,). ``omega_s_s`` is the platform's."""

    omega_r_r: np.ndarray
    alpha_r_r: np.ndarray
    omega_p_p: np.ndarray
    alpha_p_p: np.ndarray
    omega_q_q: np.ndarray
    alpha_q_q: np.ndarray
    omega_s_s: np.ndarray
    alpha_s_s: np.ndarray


def four_gimbal_rates(
    omega_b_b: Sequence[float],
    alpha_b_b: Sequence[float],
    angles: Sequence[float],
    rates: Sequence[float],
    accels: Sequence[float],
) -> FourGimbalRates:
    """Inertial rates and accelerations of the r, p, q and s (platform) frames.

    ``omega_b_b``/``alpha_b_b``: base inertial rate [rad/s] and acceleration [rad/s²] in b,
    shape (3,). ``angles``/``rates``/``accels``: (a, q, p, r) gimbal angles [rad], rates
    [rad/s] and accelerations [rad/s²], shape (4,). Same recursion as
    ``sighting_chain.chain_rates``.
    """
    w = _unpack(omega_b_b, 3, "omega_b_b")
    al = _unpack(alpha_b_b, 3, "alpha_b_b")
    a, q, p, r = _unpack(angles, 4, "angles")
    da, dq, dp, dr = _unpack(rates, 4, "rates")
    dda, ddq, ddp, ddr = _unpack(accels, 4, "accels")
    out = []
    # (rotation, cos, sin, axis index, rate, accel) outer to inner
    for rot, ang, d, dd, axis in ((_r1, r, dr, ddr, 0), (_r2, p, dp, ddp, 1),
                                  (_r1, q, dq, ddq, 0), (_r3, a, da, dda, 2)):
        c, s = math.cos(ang), math.sin(ang)
        carried = rot(c, s, *w)
        ca = list(rot(c, s, *al))
        w1 = list(carried)
        w1[axis] += d
        ca[axis] += dd
        # carried × (d e_axis): the transport term of the rotating joint axis
        x, y, z = carried
        if axis == 0:
            ca[1] += d * z
            ca[2] -= d * y
        elif axis == 1:
            ca[0] -= d * z
            ca[2] += d * x
        else:
            ca[0] += d * y
            ca[1] -= d * x
        w, al = tuple(w1), tuple(ca)
        out.extend((np.array(w), np.array(al)))
    return FourGimbalRates(*out)


def platform_rate_s(
    omega_b_b: Sequence[float], angles: Sequence[float], rates: Sequence[float]
) -> np.ndarray:
    """Platform inertial rate ω_s resolved in s [rad/s], shape (3,).

    ω_s = C_sb ω_b + C_sr θ̇_r e1 + C_sp θ̇_p e2 + C_sq θ̇_q e1 + θ̇_a e3, evaluated as the
    outer-to-inner recursion. ``omega_b_b`` (3,) [rad/s]; ``angles``/``rates`` (4,) in
    (a, q, p, r) order [rad, rad/s].
    """
    w = np.array(_unpack(omega_b_b, 3, "omega_b_b"))
    return np.array(fk.platform_rate_s(w, np.array(_unpack(angles, 4, "angles")), np.array(_unpack(rates, 4, "rates"))))


def outer_member_rates(
    omega_b_b: Sequence[float], angles: Sequence[float], rates: Sequence[float]
) -> tuple[float, float, float, float]:
    """Inertial rate [rad/s] of each joint's outer member about that joint's axis, in (a, q, p, r)
    order: the inner-roll gimbal about q-z, the pitch gimbal about p-x, the outer-roll gimbal
    about r-y, the base about b-x (the recursion of :func:`platform_rate_s`, stopped before
    each joint's own rate). What a moving base feeds into each gimbal loop."""
    x, y, z = _unpack(omega_b_b, 3, "omega_b_b")
    a, q, p, r = _unpack(angles, 4, "angles")
    _, dq, dp, dr = _unpack(rates, 4, "rates")
    w_r = x
    x, y, z = _r1(math.cos(r), math.sin(r), x, y, z)
    w_p = y
    x, y, z = _r2(math.cos(p), math.sin(p), x + dr, y, z)
    w_q = x
    x, y, z = _r1(math.cos(q), math.sin(q), x, y + dp, z)
    return z, w_q, w_p, w_r


def _pitch_gimbal_carried(
    omega_b_b: Sequence[float], p: float, r: float, dr: float
) -> tuple[float, float, float]:
    """Inertial rate of the outer-roll gimbal (base rate + θ̇_r) resolved in p [rad/s]."""
    x, y, z = _unpack(omega_b_b, 3, "omega_b_b")
    x, y, z = _r1(math.cos(r), math.sin(r), x, y, z)
    return _r2(math.cos(p), math.sin(p), x + dr, y, z)


def gimbal_rates_given_outer_roll(
    omega_s_s: Sequence[float],
    omega_b_b: Sequence[float],
    angles: Sequence[float],
    theta_r_dot: float = 0.0,
) -> np.ndarray:
    """Gimbal rates (θ̇_a, θ̇_q, θ̇_p, θ̇_r) [rad/s] that give the platform rate ``omega_s_s``.

    The paper's loop structure: the outer-roll rate ``theta_r_dot`` is set by its own null
    loop, and the azimuth, inner-roll and pitch gimbals realise the platform rate demand
    ``omega_s_s`` (3,) [rad/s, in s] against the base rate ``omega_b_b`` (3,) [rad/s, in b].
    With u = C_qs ω_s and z = C_qp ω_(r, in p):

        θ̇_q = u1 - z1,   θ̇_p = (u2 - z2) / cos θ_q,   θ̇_a = u3 - z3 + θ̇_p sin θ_q

    Returns shape (4,). Raises ``ValueError`` within ``GIMBAL_LOCK_MARGIN`` of θ_q = ±90°.
    """
    a, q, p, r = _unpack(angles, 4, "angles")
    cq, sq = math.cos(q), math.sin(q)
    _lock_check(cq, q, "inner-roll gimbal", "azimuth and pitch axes align")
    wx, wy, wz = _unpack(omega_s_s, 3, "omega_s_s")
    u1, u2, u3 = _r3(math.cos(a), -math.sin(a), wx, wy, wz)
    z1, z2, z3 = _r1(cq, sq, *_pitch_gimbal_carried(omega_b_b, p, r, theta_r_dot))
    dp = (u2 - z2) / cq
    return np.array((u3 - z3 + dp * sq, u1 - z1, dp, float(theta_r_dot)))


def gimbal_rates_given_inner_roll(
    omega_s_s: Sequence[float],
    omega_b_b: Sequence[float],
    angles: Sequence[float],
    theta_q_dot: float = 0.0,
) -> np.ndarray:
    """Gimbal rates (θ̇_a, θ̇_q, θ̇_p, θ̇_r) [rad/s] with the inner-roll rate prescribed.

    Redundancy resolved the way the outer-roll loop works in steady state: the inner roll
    moves at ``theta_q_dot`` (0 holds it; -θ_q/τ returns it to null) and the outer roll, pitch
    and azimuth realise the platform rate ``omega_s_s`` (3,) [rad/s, in s] against the base
    rate ``omega_b_b`` (3,) [rad/s, in b]. In p, with y = C_pq C_qs ω_s - θ̇_q e1 and
    w = C_pb ω_b:

        θ̇_r = (y1 - w1) / cos θ_p,  θ̇_a = (y3 - w3 - θ̇_r sin θ_p) / cos θ_q,
        θ̇_p = y2 - w2 + θ̇_a sin θ_q

    Returns shape (4,). Raises ``ValueError`` within ``GIMBAL_LOCK_MARGIN`` of θ_p = ±90°
    (outer-roll and azimuth axes align) or θ_q = ±90°.
    """
    a, q, p, r = _unpack(angles, 4, "angles")
    cp, sp = math.cos(p), math.sin(p)
    cq, sq = math.cos(q), math.sin(q)
    _lock_check(cp, p, "pitch gimbal", "outer-roll and azimuth axes align")
    _lock_check(cq, q, "inner-roll gimbal", "azimuth and pitch axes align")
    wx, wy, wz = _unpack(omega_s_s, 3, "omega_s_s")
    y1, y2, y3 = _r1(cq, -sq, *_r3(math.cos(a), -math.sin(a), wx, wy, wz))
    y1 -= theta_q_dot
    w1, w2, w3 = _pitch_gimbal_carried(omega_b_b, p, r, 0.0)
    dr = (y1 - w1) / cp
    da = (y3 - w3 - dr * sp) / cq
    return np.array((da, float(theta_q_dot), y2 - w2 + da * sq, dr))


# --------------------------------------------------------------------------------------------
# servo control signals (paper eq. 1)

class InnerGimbalSignals(NamedTuple):
    """Gimbal-angle errors [rad] of the three pickoff-driven loops (paper's Δθ_qm, Δθ_pm,
    Δθ_am): how far each gimbal is beyond the angle that re-centres the gyro pickoffs."""

    inner_roll: float
    pitch: float
    azimuth: float


def inner_gimbal_control_signals(
    pickoff_s: Sequence[float], theta_a: float, theta_q: float = 0.0
) -> InnerGimbalSignals:
    """Resolve the gyro pickoff angles onto the inner-roll, pitch and azimuth axes (eq. 1).

    ``pickoff_s``: (Δθ_gx, Δθ_gy, Δθ_gz) [rad], the small rotation of the platform away from
    its gyro reference, resolved in s, shape (3,). ``theta_a``, ``theta_q``: azimuth and
    inner-roll gimbal angles [rad]. With v = C_qs Δθ_g:

        Δθ_qm = v1,   Δθ_pm = v2 / cos θ_q,   Δθ_am = v3 + v2 tan θ_q

    which at inner-roll null (the default θ_q = 0) is the paper's rotation through θ_a.
    Exact to first order in the pickoff angles. Raises ``ValueError`` within
    ``GIMBAL_LOCK_MARGIN`` of θ_q = ±90°.
    """
    cq = math.cos(theta_q)
    _lock_check(cq, theta_q, "inner-roll gimbal", "azimuth and pitch axes align")
    gx, gy, gz = _unpack(pickoff_s, 3, "pickoff_s")
    return InnerGimbalSignals(*inner_signals(gx, gy, gz, float(theta_a), float(theta_q)))


def outer_roll_control_signal(theta_q: float, theta_p: float) -> float:
    """Outer-roll null signal Δθ_rm = θ_q sec θ_p [rad] (paper eq. 1).

    The outer-roll increment that, with the platform held by the inner loops, returns the
    inner-roll gimbal to null to first order. Raises ``ValueError`` within
    ``GIMBAL_LOCK_MARGIN`` of θ_p = ±90°, where sec θ_p is unbounded.
    """
    cp = math.cos(theta_p)
    _lock_check(cp, theta_p, "pitch gimbal", "outer-roll and azimuth axes align, sec θ_p is unbounded")
    return theta_q / cp


# --------------------------------------------------------------------------------------------
# platform rotation command (paper eqs. 2-4)

def command_rate_s(
    lat: float,
    phi_z: float,
    phi_z_dot: float,
    v_n: Sequence[float] | None = None,
    h: float = 0.0,
    drift_s: Sequence[float] | None = None,
) -> np.ndarray:
    """Gyro torquing rate command ω_c [rad/s] in the platform frame s, shape (3,).

    ω_c = rot3(φz) (ω_ie^n + ω_en^n) + φ̇z e3 - ε̂_s holds the platform level in the NED frame
    n while it turns by φz [rad] at φ̇z [rad/s] about NED down (paper eq. 2 with ENU t → NED n).
    ``lat`` [rad]; ``v_n`` NED ground velocity [m/s] (None = static, no transport rate);
    ``h`` height [m]; ``drift_s`` estimated gyro drift ε̂ [rad/s] in s, subtracted because a
    drifting gyro reference precesses at the torquing rate plus its drift.
    """
    w = earth_rate_n(lat)
    if v_n is not None:
        w = w + transport_rate_n(lat, h, np.asarray(v_n, dtype=float))
    out = np.array(command_rate_from_n(w, phi_z, phi_z_dot))
    if drift_s is not None:
        out -= np.asarray(_unpack(drift_s, 3, "drift_s"))
    return out


def command_rate_from_n(omega_n: Sequence[float], phi_z: float, phi_z_dot: float) -> tuple[float, float, float]:
    """ω_c^s = rot3(φz) ω_c^n + φ̇z e3 [rad/s]: a level command rate ω_c^n (NED) resolved into
    the platform turned by φz [rad] about NED down, plus the modulation rate φ̇z [rad/s] (the
    form of :func:`command_rate_s`; a navigator's ω_c^n carries its own earth and transport
    rates and drift compensation)."""
    x, y, z = _r3(math.cos(phi_z), math.sin(phi_z), float(omega_n[0]), float(omega_n[1]), float(omega_n[2]))
    return x, y, z + phi_z_dot


@dataclass(frozen=True)
class BidirectionalRotation:
    """Back-and-forth modulation schedule φz(t) about the platform vertical (NED down).

    The platform turns at ``rate_deg_s`` through ``sweep_deg`` (paper 3: 1.2°/s; "rotates
    bi-directionally along the z-axis in one circle", hence 360°), reverses, and comes back
    to 0, periodically; the first leg runs in the positive (clockwise from above) sense from
    φz = 0 at t = 0. The paper states only that a reversal takes "tens of milliseconds";
    ``reversal_time_s`` models it as a constant angular deceleration/acceleration centred on
    the turning point, so the extreme angles stay exactly 0 and the sweep (0 = ideal
    instantaneous reversal). Reversal k (k = 0, 1, ...) is at t_k = k·T_leg with
    T_leg = sweep/rate + reversal_time/2; at t = 0 the platform starts from rest.
    """

    rate_deg_s: float = PAPER_ROTATION_RATE_DEG_S
    sweep_deg: float = 360.0
    reversal_time_s: float = 0.0
    _rate: float = field(init=False, repr=False, compare=False)
    _sweep: float = field(init=False, repr=False, compare=False)
    _leg: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("rate_deg_s", "sweep_deg", "reversal_time_s"):
            val = getattr(self, name)
            if not isinstance(val, (int, float)) or not math.isfinite(val):
                raise ValueError(f"{name} must be a finite number, got {val!r}")
        if self.rate_deg_s <= 0.0:
            raise ValueError(f"rate_deg_s must be > 0, got {self.rate_deg_s}")
        if self.sweep_deg <= 0.0:
            raise ValueError(f"sweep_deg must be > 0, got {self.sweep_deg}")
        if self.reversal_time_s < 0.0:
            raise ValueError(f"reversal_time_s must be >= 0, got {self.reversal_time_s}")
        rate = math.radians(self.rate_deg_s)
        sweep = math.radians(self.sweep_deg)
        # the two half-ramps of one leg turn the platform by rate·T_rev/2 in total
        if 0.5 * rate * self.reversal_time_s > sweep:
            raise ValueError(
                f"reversal_time_s = {self.reversal_time_s} s is too long: the reversal ramps "
                f"alone would exceed sweep_deg = {self.sweep_deg}"
            )
        object.__setattr__(self, "_rate", rate)
        object.__setattr__(self, "_sweep", sweep)
        object.__setattr__(self, "_leg", sweep / rate + 0.5 * self.reversal_time_s)

    @property
    def rate_rad_s(self) -> float:
        """Cruise modulation rate [rad/s]."""
        return self._rate

    @property
    def leg_duration_s(self) -> float:
        """Time between reversals [s]; the period is twice this."""
        return self._leg

    def reversal_times(self, t_end: float) -> np.ndarray:
        """Reversal instants t_k in (0, t_end] [s], shape (k,)."""
        n = int(math.floor(t_end / self._leg + 1e-12))
        return self._leg * np.arange(1, max(n, 0) + 1, dtype=float)

    def _phase(self, t: float) -> tuple[int, float]:
        k = math.floor(t / self._leg)
        return k, t - k * self._leg

    def state(self, t: float) -> tuple[float, float, float]:
        """(φz [rad], φ̇z [rad/s], φ̈z [rad/s²]) at time ``t`` [s] (t < 0 is held at rest)."""
        if t < 0.0:
            return 0.0, 0.0, 0.0
        k, tau = self._phase(t)
        w, half = self._rate, 0.5 * self.reversal_time_s
        # within a leg of direction +1: start at 0, ramp up, cruise, ramp down to sweep
        if half > 0.0 and tau < half:
            acc = w / half
            ang, rate = 0.5 * acc * tau * tau, acc * tau
        elif half > 0.0 and tau > self._leg - half:
            acc = -w / half
            rem = self._leg - tau
            ang, rate = self._sweep - 0.5 * w / half * rem * rem, w / half * rem
        else:
            acc = 0.0
            ang, rate = w * half / 2.0 + w * (tau - half), w
        if k % 2:
            return self._sweep - ang, -rate, -acc
        return ang, rate, acc

    def angle(self, t: float) -> float:
        """Modulation angle φz [rad] at ``t`` [s]."""
        return self.state(t)[0]

    def rate(self, t: float) -> float:
        """Modulation rate φ̇z [rad/s] at ``t`` [s]."""
        return self.state(t)[1]
