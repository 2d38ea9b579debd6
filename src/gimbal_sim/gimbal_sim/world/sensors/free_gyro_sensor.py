"""Free gyros of the free-gyro positioning and directional system (paper 4, docs/spec.md §3.4).

What is simulated (paper 4 §2.3, Figs. 3–4): two free gyros whose spin axes u_a, u_b keep a
fixed direction in inertial space, read out in the ship's body frame by their pickoffs, a
body gyro triad (earth rate + ship rate), and the vertical reference that levels them.

* Inertial frame ``i`` as in :mod:`gimbal_kinematics.maths.free_gyro`: x_i toward Greenwich at
  t = 0, z_i along the earth's axis; t is the simulation time [s].
* Spin axis in the body: ``u_b = C_bn(roll, pitch, yaw) · C_ni(lat, lon, t) · u_i(t)``. The
  true axis wanders (paper 4's closing section: "the additional drift ... when a free gyro is
  suppressed by the measures which prevent gimbals lock and tumbling"); every term defaults
  to 0, an ideal free gyro:

  - caging error: the rotor is released from its cage (uncaged) a random constant angle c ⊥ u
    away from where it was set, σ ``caging_error_arcsec`` per axis;
  - constant drift: a random-constant rate d ⊥ u, σ ``spin_drift_sigma_deg_h`` per axis;
  - Gauss–Markov drift: a first-order Gauss–Markov rate x ⊥ u (two components in a fixed
    basis ⊥ the set axis), stationary from t = 0, σ ``gm_drift_sigma_deg_h``, correlation
    time ``gm_drift_tau_s``: x_{k+1} = e^{−Δt/τ} x_k + σ √(1 − e^{−2Δt/τ}) w_k (exact);
  - gimbal-lock suppression: the outer gimbal axis is the case's z (down). When the spin
    axis comes within ``lock_guard_deg`` of it (or of −z), a suppression torque precesses the
    axis away from it at ``lock_suppression_rate_deg_h`` (0 guard: none).

  Without the Gauss–Markov and suppression terms u_i(t) = exp([d t ×]) exp([c ×]) u_i(0) in
  closed form; with them the axis is stepped read-out by read-out, turned by the step's mean
  rate.
* Spin-axis sensors: with ``spin_rate_arw_deg_rt_h`` > 0 the two sensors of the spin axis's
  motion (paper 4 §2.3, Fig. 3) are rate sensors whose outputs are integrated from the
  setting time t = 0, not angle pickoffs: the integrated read-out is the true axis turned by
  the integral of the sensors' white rate noise, a random walk ⊥ u (resolved in the gyro
  frame, eq. 19) whose variance grows as N² t per axis. The true rate integrates exactly (the
  error, not the mechanisation's numerics, is simulated).
* Pickoff noise: white per sample, isotropic in the plane ⊥ u_b with σ =
  ``pickoff_noise_arcsec`` per axis (the read-out direction is renormalised): the angle
  pickoffs' noise, or the integrated rate sensors' read-out (quantisation) noise. Its component
  in the vertical plane through u is the nadir-angle error (σ), its horizontal component
  the gyro-azimuth error (σ / sin θ).
* Body triad: :class:`GyroModel` (``triad`` parameters, 3 axes) fed the step-average
  inertial body rate ω_ib^b [rad/s] (``VehicleTruth.delta_angle_b / Δt``).
* Vertical reference: roll and pitch with a fixed bias and white noise (arcsec). A levelling
  error is common to both gyros, so it correlates their nadir-angle errors — outside paper 4's
  i.i.d. FDOP model; the default is an exact vertical.
* Sailing (``speed_m_s`` > 0): the ship leaves the site it is given (the vehicle's, whose
  body rates hold the earth rate there) at t = 0 on a rhumb line of ``course_deg``
  (:func:`sailing_position`). The spin axes are read out at the ship's position at t, and
  the triad also senses C_b^n (ω_ie^n(φ(t)) − ω_ie^n(φ₀) + ω_en^n), the transport rate and
  the change of the earth rate along the track, which the host-only vehicle leaves out.

Everything is seeded from the caller's ``numpy.random.Generator``; angles rad, rates rad/s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.earth import (
    OMEGA_IE, earth_rate_n, meridian_radius, prime_vertical_radius, transport_rate_n,
)
from gimbal_kinematics.maths.free_gyro import dcm_ni, unit_vector
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, euler321_to_dcm

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import ARCSEC, DEG_H, DEG_RT_H
from ._normals import NormalStream
from .gyro import GyroModel, GyroParams

#: Body triad default: a navigation-grade triad (ARW 0.002 °/√h); the paper gives no figure.
FREE_GYRO_TRIAD = GyroParams(arw_deg_rt_h=0.002)


@dataclass(frozen=True)
class FreeGyroSensorParams:
    """Free-gyro sensor parameters (validated, immutable).

    Attributes:
        u_a_i, u_b_i: spin axes at t = 0 in the inertial frame (unit 3-vectors, not parallel).
        pickoff_noise_arcsec: white read-out noise σ per axis ⊥ the spin axis, per sample [″].
        spin_drift_sigma_deg_h: σ per ⊥ axis of a random-constant spin-axis drift drawn per
            run [°/h] (0 = ideal free gyro).
        level_noise_arcsec: white noise σ of the vertical reference's roll and pitch [″].
        level_bias_arcsec: fixed (roll, pitch) error of the vertical reference [″].
        triad: body gyro triad error parameters.
        speed_m_s, course_deg: the ship's speed over ground [m/s] and course [deg from
            north toward east] (0: the ship stays at its site).
        caging_error_arcsec: σ per ⊥ axis of each rotor's random-constant uncaging error [″].
        gm_drift_sigma_deg_h, gm_drift_tau_s: σ per ⊥ axis [°/h] and correlation time [s] of
            the first-order Gauss–Markov spin-axis drift (0 σ: none).
        lock_guard_deg, lock_suppression_rate_deg_h: gimbal-lock suppression: within this
            angle [deg] of the outer gimbal axis (case z) the axis is precessed away at this
            rate [°/h] (0 guard: none).
        spin_rate_arw_deg_rt_h: angle random walk of the spin-axis rate sensors, whose
            outputs are integrated from t = 0 [°/√h] (0: angle pickoffs, no random walk).
    """

    u_a_i: tuple[float, float, float]
    u_b_i: tuple[float, float, float]
    pickoff_noise_arcsec: float = 5.0
    spin_drift_sigma_deg_h: float = 0.0
    level_noise_arcsec: float = 0.0
    level_bias_arcsec: tuple[float, float] = (0.0, 0.0)
    triad: GyroParams = field(default_factory=lambda: FREE_GYRO_TRIAD)
    speed_m_s: float = 0.0
    course_deg: float = 0.0
    caging_error_arcsec: float = 0.0
    gm_drift_sigma_deg_h: float = 0.0
    gm_drift_tau_s: float = 300.0
    lock_guard_deg: float = 0.0
    lock_suppression_rate_deg_h: float = 0.0
    spin_rate_arw_deg_rt_h: float = 0.0

    def __post_init__(self) -> None:
        a = unit_vector(self.u_a_i, "u_a_i")
        b = unit_vector(self.u_b_i, "u_b_i")
        object.__setattr__(self, "u_a_i", a)
        object.__setattr__(self, "u_b_i", b)
        cx = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        if math.sqrt(sum(c * c for c in cx)) < 1e-6:
            raise ValueError("u_b_i must not be parallel or antiparallel to u_a_i (no position fix)")
        v.nonneg_finite("pickoff_noise_arcsec", self.pickoff_noise_arcsec)
        v.nonneg_finite("spin_drift_sigma_deg_h", self.spin_drift_sigma_deg_h)
        v.nonneg_finite("level_noise_arcsec", self.level_noise_arcsec)
        object.__setattr__(self, "level_bias_arcsec", v.per_axis("level_bias_arcsec", self.level_bias_arcsec, 2))
        if not isinstance(self.triad, GyroParams):
            raise ValueError(f"triad must be GyroParams, got {type(self.triad).__name__}")
        v.nonneg_finite("speed_m_s", self.speed_m_s)
        v.finite("course_deg", self.course_deg)
        for name in ("caging_error_arcsec", "gm_drift_sigma_deg_h", "lock_suppression_rate_deg_h",
                     "spin_rate_arw_deg_rt_h"):
            v.nonneg_finite(name, getattr(self, name))
        v.positive("gm_drift_tau_s", self.gm_drift_tau_s)
        if not (0.0 <= self.lock_guard_deg < 90.0):
            raise ValueError(f"lock_guard_deg must be in [0, 90), got {self.lock_guard_deg!r}")

    @property
    def velocity_n(self) -> tuple[float, float, float]:
        """The ship's NED ground velocity [m/s] (level: the course is a rhumb line)."""
        c = math.radians(self.course_deg)
        return self.speed_m_s * math.cos(c), self.speed_m_s * math.sin(c), 0.0


def sailing_position(lat0: float, lon0: float, v_n: Sequence[float], t: float) -> tuple[float, float]:
    """Geodetic (lat, lon) [rad] at ``t`` [s] of a ship that left (lat0, lon0) [rad] at t = 0
    with constant NED ground velocity ``v_n`` [m/s] (a rhumb line at the surface): dφ/dt =
    v_N / R_M (R_M taken at φ₀: the track is a few km), and dλ/dt = v_E / (R_N cos φ)
    integrated in closed form, λ − λ₀ = v_E/(R_N φ̇) (atanh sin φ − atanh sin φ₀)."""
    rate = float(v_n[0]) / meridian_radius(lat0)
    lat = lat0 + rate * t
    rn = prime_vertical_radius(lat0)
    if abs(rate * t) < 1e-12:
        dlon = float(v_n[1]) * t / (rn * math.cos(lat0))
    else:
        dlon = float(v_n[1]) / (rn * rate) * (math.atanh(math.sin(lat)) - math.atanh(math.sin(lat0)))
    return lat, lon0 + dlon


class FreeGyroSample(NamedTuple):
    """One read-out at ``t`` [s].

    Measured: ``spin_a_b``, ``spin_b_b`` unit spin axes in body FRD; ``omega_ib_b`` triad
    rate [rad/s] (step average); ``roll``, ``pitch`` vertical reference [rad].
    Truth: ``true_spin_a_b``/``true_spin_b_b``, ``true_nadir`` (θ_a, θ_b) and
    ``true_azimuth`` (α_a, α_b) [rad] at the true position, ``true_euler`` (roll, pitch, yaw),
    ``true_omega_ie_b`` earth rate resolved in b [rad/s], ``true_triad_bias`` [rad/s],
    ``true_lat``, ``true_lon`` [rad] the ship's position and ``velocity_n`` its NED ground
    velocity [m/s].
    """

    t: float
    spin_a_b: tuple[float, float, float]
    spin_b_b: tuple[float, float, float]
    omega_ib_b: tuple[float, float, float]
    roll: float
    pitch: float
    true_spin_a_b: tuple[float, float, float]
    true_spin_b_b: tuple[float, float, float]
    true_nadir: tuple[float, float]
    true_azimuth: tuple[float, float]
    true_euler: tuple[float, float, float]
    true_omega_ie_b: tuple[float, float, float]
    true_triad_bias: tuple[float, float, float]
    true_lat: float = float("nan")
    true_lon: float = float("nan")
    velocity_n: tuple[float, float, float] = (0.0, 0.0, 0.0)


class FreeGyroSensor:
    """Two free gyros + body triad + vertical reference (module docstring).

    Args:
        params: sensor parameters.
        rng: the run's seeded Generator; split into independent streams for the pickoffs,
            the spin drift, the triad and the vertical reference.
        dt: nominal sample interval [s] (the triad's step).
    """

    def __init__(self, params: FreeGyroSensorParams, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, FreeGyroSensorParams)
        v.of_type("rng", rng, np.random.Generator, "a numpy.random.Generator")
        v.positive("dt", dt)
        self.params = params
        r_pick, r_drift, r_triad, r_level = rng.spawn(4)
        self._pick = NormalStream(r_pick)
        self._level = NormalStream(r_level)
        self.triad = GyroModel(params.triad, 3, r_triad, dt)
        self._u0 = (np.array(params.u_a_i), np.array(params.u_b_i))
        self._drift = []
        sd = params.spin_drift_sigma_deg_h * DEG_H
        for u in self._u0:
            d = r_drift.standard_normal(3) * sd
            self._drift.append(d - (d @ u) * u)  # only ⊥ components move the axis
        # the drift terms and the rate sensors draw from streams of their own (spawned after
        # the four above, so that those, and every run without the new terms, are unchanged)
        r_cage, r_gm, r_rate = rng.spawn(3)
        self._perp = []   # an orthonormal basis (e1, e2) ⊥ each set axis, in i
        for u in self._u0:
            e1 = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
            e1 /= np.linalg.norm(e1)
            self._perp.append((e1, np.cross(u, e1)))
        sc = params.caging_error_arcsec * ARCSEC
        self._cage = [sc * (r_cage.standard_normal() * e1 + r_cage.standard_normal() * e2) for e1, e2 in self._perp]
        self._u_rel = [dcm_from_rotation_vector(c) @ u if c.any() else u.copy() for c, u in zip(self._cage, self._u0)]
        self._gm_sigma = params.gm_drift_sigma_deg_h * DEG_H
        self._gm = NormalStream(r_gm)
        self._gm_x = [self._gm_sigma * np.array([self._gm.one(), self._gm.one()]) for _ in self._u0]
        self._lock_cos = math.cos(math.radians(params.lock_guard_deg)) if params.lock_guard_deg > 0.0 else 2.0
        self._lock_rate = params.lock_suppression_rate_deg_h * DEG_H
        self._stepped = self._gm_sigma > 0.0 or (self._lock_cos <= 1.0 and self._lock_rate > 0.0)
        self._u_now = [u.copy() for u in self._u_rel]   # the stepped axes (Gauss–Markov, suppression)
        self._t_axes = 0.0
        self._lock_time = [0.0, 0.0]
        self._rate_n = params.spin_rate_arw_deg_rt_h * DEG_RT_H
        self._rate = NormalStream(r_rate)
        self._rw = [np.zeros(3), np.zeros(3)]   # integrated rate-sensor error ⊥ u, in i
        self._t_rw = 0.0
        self._sigma = params.pickoff_noise_arcsec * ARCSEC
        self._level_sigma = params.level_noise_arcsec * ARCSEC
        self._level_bias = tuple(b * ARCSEC for b in params.level_bias_arcsec)  # type: ignore[union-attr]
        self._t_last: float | None = None

    @property
    def spin_drift_i(self) -> tuple[np.ndarray, np.ndarray]:
        """Drawn spin-axis drift rate vectors d (3,) [rad/s] in i, one per gyro."""
        return self._drift[0].copy(), self._drift[1].copy()

    @property
    def caging_error_i(self) -> tuple[np.ndarray, np.ndarray]:
        """Drawn uncaging errors c (3,) [rad] in i, one per gyro (⊥ the set axis)."""
        return self._cage[0].copy(), self._cage[1].copy()

    @property
    def released_axes_i(self) -> tuple[np.ndarray, np.ndarray]:
        """The spin axes (3,) at release (t = 0): the set axes turned by the uncaging error."""
        return self._u_rel[0].copy(), self._u_rel[1].copy()

    @property
    def gm_drift_rates(self) -> tuple[np.ndarray, np.ndarray]:
        """The Gauss–Markov drift rates (2,) [rad/s] of each gyro at the last read-out, in
        its fixed basis ⊥ the set axis."""
        return self._gm_x[0].copy(), self._gm_x[1].copy()

    @property
    def rate_sensor_error_i(self) -> tuple[np.ndarray, np.ndarray]:
        """The integrated rate sensors' error angles (3,) [rad] in i at the last read-out."""
        return self._rw[0].copy(), self._rw[1].copy()

    @property
    def lock_suppression_time_s(self) -> tuple[float, float]:
        """Time [s] each gyro has spent within the gimbal-lock guard so far."""
        return self._lock_time[0], self._lock_time[1]

    def spin_axes_i(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """True spin axes u_i(t) (3,) at time ``t`` [s]: in closed form, or, with the
        Gauss–Markov drift or the suppression on, the axes stepped to the last read-out."""
        if self._stepped:
            return self._u_now[0].copy(), self._u_now[1].copy()
        out = []
        for u, d in zip(self._u_rel, self._drift):
            out.append(dcm_from_rotation_vector(d * t) @ u if d.any() else u.copy())
        return out[0], out[1]

    def _step_axes(self, t: float, C_bi: np.ndarray) -> None:
        """Turn the stepped axes from the last read-out to ``t`` by the step's mean rate:
        constant drift + the Gauss–Markov rate (trapezoid of its two samples) + the
        suppression's precession where the axis at the step's start, seen in the case at t
        (``C_bi`` maps i to b at t), is within the guard of the outer gimbal axis."""
        h = t - self._t_axes
        self._t_axes = t
        if h <= 0.0:
            return
        phi = math.exp(-h / self.params.gm_drift_tau_s)
        q = self._gm_sigma * math.sqrt(max(1.0 - phi * phi, 0.0))
        for k in (0, 1):
            e1, e2 = self._perp[k]
            x0 = self._gm_x[k]
            x1 = phi * x0 + q * np.array([self._gm.one(), self._gm.one()]) if self._gm_sigma > 0.0 else x0
            self._gm_x[k] = x1
            xm = 0.5 * (x0 + x1)
            w = self._drift[k] + xm[0] * e1 + xm[1] * e2
            u = self._u_now[k]
            if self._lock_rate > 0.0:
                c = float(C_bi[2] @ u)   # cos of the angle to the outer gimbal axis z_b
                if abs(c) >= self._lock_cos:
                    a = math.copysign(1.0, c) * C_bi[2]   # the nearer end of the outer axis, in i
                    n = np.cross(a, u)
                    nn = float(np.linalg.norm(n))
                    if nn > 1e-12:
                        w = w + self._lock_rate * n / nn   # n × u points away from a
                    self._lock_time[k] += h
            self._u_now[k] = dcm_from_rotation_vector(w * h) @ u

    def _step_rate_sensors(self, t: float) -> None:
        h = t - self._t_rw
        self._t_rw = t
        if h <= 0.0 or self._rate_n == 0.0:
            return
        s = self._rate_n * math.sqrt(h)
        for k in (0, 1):
            e1, e2 = self._perp[k]
            buf, j = self._rate.take(2)
            self._rw[k] = self._rw[k] + s * (buf[j] * e1 + buf[j + 1] * e2)

    def _read(self, u_b: np.ndarray) -> tuple[float, float, float]:
        if self._sigma == 0.0:
            return float(u_b[0]), float(u_b[1]), float(u_b[2])
        buf, j = self._pick.take(3)
        nx, ny, nz = buf[j] * self._sigma, buf[j + 1] * self._sigma, buf[j + 2] * self._sigma
        ux, uy, uz = float(u_b[0]), float(u_b[1]), float(u_b[2])
        along = nx * ux + ny * uy + nz * uz
        x, y, z = ux + nx - along * ux, uy + ny - along * uy, uz + nz - along * uz
        n = math.sqrt(x * x + y * y + z * z)
        return x / n, y / n, z / n

    def update(self, t: float, lat: float, lon: float, euler: Sequence[float],
               omega_ib_b: Sequence[float], dt: float | None = None) -> FreeGyroSample:
        """Read-out at ``t`` [s] for a ship with attitude ``euler`` = (roll, pitch, yaw)
        [rad] and step-average inertial rate ``omega_ib_b`` (3,) [rad/s] over the step ending
        at t, at geodetic (lat, lon) [rad], or sailing from there at t = 0 (module
        docstring). Times must increase."""
        if self._t_last is not None and not t > self._t_last:
            raise ValueError(f"t must increase: {t} after {self._t_last}")
        self._t_last = t
        roll, pitch, yaw = (float(e) for e in euler)
        C_bn = euler321_to_dcm(roll, pitch, yaw).T
        v_n = self.params.velocity_n
        if self.params.speed_m_s > 0.0:
            lat0 = lat
            lat, lon = sailing_position(lat, lon, v_n, t)
            extra_n = earth_rate_n(lat) - earth_rate_n(lat0) + transport_rate_n(lat, 0.0, np.array(v_n))
            omega_ib_b = np.asarray(omega_ib_b, dtype=float) + C_bn @ extra_n
        C_ni = dcm_ni(lat, lon, t)
        if self._stepped:
            self._step_axes(t, C_bn @ C_ni)
        u_a, u_b = self.spin_axes_i(t)
        un_a, un_b = C_ni @ u_a, C_ni @ u_b
        ua_b, ub_b = C_bn @ un_a, C_bn @ un_b
        if self._rate_n > 0.0:   # integrated rate sensors: the read-out turned by their error
            self._step_rate_sensors(t)
            C_bi = C_bn @ C_ni
            ma, mb = (dcm_from_rotation_vector(e) @ u for e, u in zip(self._rw, (u_a, u_b)))
            ma_b, mb_b = C_bi @ ma, C_bi @ mb
        else:
            ma_b, mb_b = ua_b, ub_b
        w = self.triad.step_rate([float(c) for c in omega_ib_b], dt)
        lr, lp = self._level_bias
        if self._level_sigma > 0.0:
            buf, j = self._level.take(2)
            lr += self._level_sigma * buf[j]
            lp += self._level_sigma * buf[j + 1]
        nadir = (math.atan2(math.hypot(un_a[0], un_a[1]), un_a[2]), math.atan2(math.hypot(un_b[0], un_b[1]), un_b[2]))
        azimuth = (math.atan2(un_a[1], un_a[0]), math.atan2(un_b[1], un_b[0]))
        w_ie_b = C_bn @ (C_ni[:, 2] * OMEGA_IE)  # ω_ie^i = Ω e3
        return FreeGyroSample(
            t=float(t), spin_a_b=self._read(ma_b), spin_b_b=self._read(mb_b),
            omega_ib_b=(float(w[0]), float(w[1]), float(w[2])), roll=roll + lr, pitch=pitch + lp,
            true_spin_a_b=tuple(float(c) for c in ua_b), true_spin_b_b=tuple(float(c) for c in ub_b),
            true_nadir=(float(nadir[0]), float(nadir[1])), true_azimuth=(float(azimuth[0]), float(azimuth[1])),
            true_euler=(roll, pitch, yaw), true_omega_ie_b=tuple(float(c) for c in w_ie_b),
            true_triad_bias=tuple(float(c) for c in self.triad.true_bias), true_lat=float(lat), true_lon=float(lon),
            velocity_n=v_n,
        )

    def update_from_truth(self, truth, lat: float, lon: float, dt: float) -> FreeGyroSample:
        """Read-out from a ``gimbal_sim.world.vehicle.VehicleTruth`` (its site at (lat, lon) [rad]);
        the triad gets the exact step rotation ``delta_angle_b / dt``."""
        w = np.asarray(truth.delta_angle_b, dtype=float) / dt if truth.k else np.asarray(truth.omega_ib_b)
        return self.update(truth.t, lat, lon, truth.euler, w, dt)
