"""Local-level platform INS navigator of paper 3's rotational INS (§4.3; docs/spec.md §3.3).

After the fine alignment (:mod:`.rotation_alignment`) the platform keeps turning about the
local vertical while this core navigates: per sample it takes the stable element's
specific force f_s (platform axes s), the azimuth angle (resolver θ_a or servo φz: "Azimuth
source" below) and the stamp, and it returns the NED velocity, the position (latitude, longitude, height) and the platform
command rate. Pure Python, no rclpy; a node wraps it.

Frames and conventions (those of :mod:`gimbal_kinematics.maths.four_gimbal` and the alignment)
---------------------------------------------------------------------------------------
n = local-level NED. The platform azimuth ψ̂ (from the azimuth source, below) is about NED down, and a
level platform has C_sn = rot3(ψ̂). The specific force is resolved through it (paper 3:
"the acceleration of the measurement axis needs to be resolved through the rotation angle
into the t-frame"): f_N = cos ψ̂ f_x − sin ψ̂ f_y, f_E = sin ψ̂ f_x + cos ψ̂ f_y, f_D = f_z, after
the hand-off accelerometer-bias estimate is taken off f_s. The platform's tilt is not known
to the navigator: it appears as g × tilt in f_N, f_E, which is what closes the Schuler loop.

Azimuth source (``azimuth_source``). ``resolver``: ψ̂ = θ_a + ``base_heading_deg``, the resolver
plus a known, fixed base heading: the platform azimuth on a static base (paper 3's laboratory
experiment). On a moving base θ_a is the platform's azimuth relative to a member that yaws,
rolls and pitches with the ship, so a fixed heading leaves ψ̂ off by the heading motion (±3° on
paper 5's moored ship). ``servo``: ψ̂ = φz + ``base_heading_deg``, the servo's commanded
rotation angle φz plus the platform's azimuth at φz = 0. Why φz is the platform's azimuth in
NED: the servo torques its gyro reference at ω_c = rot3(φz) ω_c^n + φ̇z e3, where ω_c^n (this
core's command) is the rate of the local-level NED frame itself (earth rate + transport rate),
so relative to NED the reference turns at φ̇z about down only, whatever the base does, and the
platform follows the reference to its pickoff δ (arc-seconds). The base's motion enters only
the gimbal angles, never φz. What φz does not know is the reference's own azimuth drift (a
vertical gyro drift ε_z turns it by ε_z t, 0.03 °/h: ~5′ in 3 h): that is the same azimuth
error a platform INS carries, whose effect on the earth-rate command is the "vertical gyro"
term of the error budget; the resolver would see it on a static base, where the heading is
known, but on a ship the heading is exactly what the INS is there to give. The angle comes as
the third argument of :meth:`PlatformNavigator.step` in both cases; a missing one (None) is
refused and counted alike (``rejected_no_resolver``).

Mechanisation (:mod:`gimbal_kinematics.maths.earth` for the WGS-84 radii, rates and gravity)
------------------------------------------------------------------------------------
    v̇ = f_n + g_n(L, h) − (2 ω_ie^n + ω_en^n) × v
    L̇ = v_N / (R_M + h),   λ̇ = v_E / ((R_N + h) cos L)

Velocity steps with the new sample's specific force and the previous velocity's Coriolis
term, position by the trapezoid of the old and new velocity. In the closed loop (platform
tilted by the previous command, then sensed, then integrated) this is the semi-implicit
Euler scheme, which keeps the undamped Schuler oscillation's amplitude instead of letting it
grow as explicit Euler would.

Vertical channel: damped by a reference altitude. A free vertical channel is unstable: the
gravity gradient ∂g/∂h ≈ −2g/R feeds a height error back positively, e^{t/τ} with
τ = √(R/2g) ≈ 570 s, so a 100 µg vertical bias alone leaves kilometres after 3 h. A real
platform INS damps it with an altimeter (barometric on aircraft) or, at sea and on a static
base, a known reference height. This core runs the classical third-order loop against the
reference height h_ref (the hand-off height; :meth:`PlatformNavigator.set_reference_height`
takes an external altimeter):

    e = h − h_ref,   ḣ = v_U − k1 e,   v̇_U = a_U − k2 e − δa,   δȧ = k3 e

(v_U = −v_D). With the gradient in g(h) the error's characteristic polynomial is
s³ + k1 s² + (k2 − 2g/R) s + k3; k1 = 3/τ_v, k2 = 3/τ_v² + 2g/R, k3 = 1/τ_v³ place a triple
pole at −1/τ_v, and the integral state δa takes up a constant vertical accelerometer error
with no steady height error. Holding h (v_D = 0) would also do on a static base, but gives
no vertical velocity to the Coriolis term and no estimate of the vertical channel on a
moving one.

Platform command rate (paper 3 eq. 2–4), resolved in NED
--------------------------------------------------------
    ω_c^n = ω_ie^n(L) + ω_en^n(v, L, h) − ε̂^n + ω_torque^n
    ε̂^n = ε̂_N e_N + rot3(ψ̂_c)ᵀ ε̂_s       (ψ̂_c: see below)

It is the rate at which the platform's gyro reference must turn so that it stays on the
local level frame, without the modulation rate. **The servo follows it in NED**: it resolves
it through its own commanded rotation angle φz and adds the modulation rate,
ω_c^s = rot3(φz) ω_c^n + φ̇z e3 (the form of
:func:`gimbal_kinematics.maths.four_gimbal.command_rate_s`; with the navigator in the loop the
servo's own earth rate and drift compensation give way to ω_c^n). The modulation schedule (φz, φ̇z, the
integrator presets at reversals) stays the servo's, and the gyro reference stays the azimuth
reference, as in any platform INS: a vertical gyro drift turns the reference and the earth
rate is then applied about the wrong axes, an error that rotation about the vertical cannot
modulate. The drift estimates ε̂_s are fixed in the platform; resolved here through ψ̂ and
back by the servo through φz, they come back to first order (ψ̂ − φz is the azimuth
misalignment, ~1′ after the alignment: 3e-4 of 0.03 °/h). The servo holds each command until
the next sample while the platform turns on, so ε̂_s is resolved at the azimuth half an
interval ahead, ψ̂ + ½ (ψ̂ − ψ̂_previous): resolved where the interval starts, the held
compensation would lag by half the turn per sample and leave a residual ε̂ ω_r Δt/2 across
the drift (at 2 Hz and 1.2 °/s, 0.5 % of ε̂). ε̂_N is the alignment's north drift, fixed in
NED. A positive ω_c^n about an NED axis turns the platform, and its
misalignment φ (C_ns,true = exp([φ×]) C_ns,ideal), positively about that axis.

Hand-off (paper 3 l. 580–582 and 707–709): navigation starts at the site with zero velocity,
the drift estimates go into ω_c^n, the accelerometer-bias estimate is subtracted from f_s,
and the misalignment φ is **torqued out by a one-time command-rate pulse**
ω_torque^n = −φ^n / T for the samples stamped less than T after the first one. A reset of the
navigator's reference instead would leave the stable element physically tilted (the
accelerometers would go on reading g × tilt, a bias the mechanisation cannot tell from
acceleration) and the gyro reference off in azimuth (the earth rate applied about the wrong
axes); torquing the gyros is what a platform INS does. Spread over T (default 10 s: 1000″
of azimuth is 0.03 °/s) the rate stays within what the servo tracks; a single-sample impulse
would step the pickoffs. The servo holds each command until the next, so the angle torqued
is φ × (time held)/T: exact when the sample period divides T. The level residual during T
costs ~g φ T/2 of velocity (1 mm/s for 5″).

Stamps come checked and in order from the node's input policy
(:mod:`gimbal_kinematics.timing.input_policy`: repeats and late stamps dropped and counted there; a
clock jump back, a bag looping, is a :meth:`PlatformNavigator.reset` to the hand-off, the
next sample the first of the new run). Bad input is counted and never integrated: a
non-finite stamp or value, a missing resolver angle or φz sample (None).

Accuracy figure: none. The core is a mechanisation without a filter; its error comes from
sensor errors it does not observe (that is the experiment's measurement), so any covariance it
published would be an assumed error budget, not a property of the solution.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.earth import meridian_radius, normal_gravity, prime_vertical_radius
from gimbal_kinematics.maths.outcome import Fed, refused
from gimbal_kinematics.maths.attribute_views import slot
from gimbal_kinematics.maths.units import ARCSEC, DEG, DEG_H, UG

from . import navigator_kernels as nk
from .platform_navigator_params import PlatformNavigatorParams


class HandOff(NamedTuple):
    """Navigation start values, SI: ``lat``, ``lon`` [rad], ``height`` [m]; ``velocity_n``
    NED [m/s] (zero on a static base); ``gyro_drift_s`` (x, y, z) [rad/s] in platform axes;
    ``north_drift`` ε̂_N [rad/s]; ``accel_bias_s`` (x, y, z) [m/s²]; ``misalignment_enu``
    (δφE, δφN, δφU) [rad] to torque out."""

    lat: float
    lon: float
    height: float
    velocity_n: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyro_drift_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    north_drift: float = 0.0
    accel_bias_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    misalignment_enu: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def from_params(cls, p: PlatformNavigatorParams) -> HandOff:
        """The start values the parameters give, in SI (the one place they are converted)."""
        return cls(p.lat_deg * DEG, p.lon_deg * DEG, float(p.height_m), (0.0, 0.0, 0.0),
                   tuple(v * DEG_H for v in p.gyro_drift_deg_h), p.north_drift_deg_h * DEG_H,  # type: ignore[arg-type]
                   tuple(v * UG for v in p.accel_bias_ug), tuple(v * ARCSEC for v in p.misalignment_arcsec))

    @classmethod
    def from_alignment(cls, estimate, lat: float, lon: float, height: float) -> HandOff:
        """From a :class:`.rotation_alignment.AlignmentEstimate` at the end of the alignment:
        its level drifts (it has no vertical one), north drift, level accelerometer biases
        and the misalignment propagated to its time; navigation starts at rest at
        (``lat``, ``lon`` [rad], ``height`` [m])."""
        ex, ey = (float(v) for v in estimate.gyro_drift_xy)
        bx, by = (float(v) for v in estimate.accel_bias_xy)
        return cls(float(lat), float(lon), float(height), (0.0, 0.0, 0.0), (ex, ey, 0.0),
                   float(estimate.north_drift), (bx, by, 0.0),
                   tuple(float(v) for v in estimate.misalignment_enu))  # type: ignore[arg-type]


class NavigatorOutput(NamedTuple):
    """One navigation step at stamp ``t_ns`` [ns]: ``velocity_n`` NED [m/s]; ``lat``,
    ``lon`` [rad], ``height`` [m]; ``command_rate_n`` ω_c^n NED [rad/s] (module docstring)
    to hold until the next step; ``azimuth`` ψ̂ [rad] used to resolve f_s; ``torquing``:
    the hand-off pulse is in ``command_rate_n``."""

    t_ns: int
    velocity_n: tuple[float, float, float]
    lat: float
    lon: float
    height: float
    command_rate_n: tuple[float, float, float]
    azimuth: float
    torquing: bool


_NONFINITE = refused("non-finite specific force or azimuth angle")
_NO_RESOLVER = refused("no azimuth angle within max_joint_age_s")


class PlatformNavigator:
    """Platform INS mechanisation core (module docstring). Feed :meth:`step` per IMU sample."""

    def __init__(self, params: PlatformNavigatorParams | None = None, hand_off: HandOff | None = None) -> None:
        self.params = params if params is not None else PlatformNavigatorParams()
        if not isinstance(self.params, PlatformNavigatorParams):
            raise TypeError(f"params must be PlatformNavigatorParams, got {type(self.params).__name__}")
        self.state = np.zeros(nk.N_STATE)  # the kernel's state vector (L, λ, h, v, δa, ...)
        self.kernel_params = np.zeros(nk.N_PARAMS)
        self.rejected_nonfinite = 0
        self.rejected_no_resolver = 0
        self.resets = 0
        self.reset_reasons: list[str] = []
        self.hand_off(hand_off if hand_off is not None else HandOff.from_params(self.params))

    # -- hand-off and restarts ---------------------------------------------------------------
    def hand_off(self, h: HandOff) -> None:
        """Start navigating from ``h`` (the alignment's result); the next sample is the first."""
        vals = (h.lat, h.lon, h.height, h.north_drift, *h.velocity_n, *h.gyro_drift_s, *h.accel_bias_s,
                *h.misalignment_enu)
        if len(vals) != 16 or not all(math.isfinite(float(v)) for v in vals):
            raise ValueError(f"hand_off: every value must be finite, 3 per vector, got {h!r}")
        if abs(h.lat) >= math.radians(89.0):
            raise ValueError(f"hand_off: latitude {math.degrees(h.lat):.3f}° is within 1° of a pole")
        self._handoff = h
        g0 = normal_gravity(h.lat, h.height)
        r0 = math.sqrt(meridian_radius(h.lat) * prime_vertical_radius(h.lat)) + h.height
        tau = self.params.vertical_tau_s
        k = (3.0 / tau, 3.0 / tau**2 + 2.0 * g0 / r0, 1.0 / tau**3)
        e, n, u = (float(v) for v in h.misalignment_enu)
        T = self.params.torque_out_s
        torque_n = (-n / T, -e / T, u / T)  # −φ^n / T with φ^n = (δφN, δφE, −δφU)
        self.kernel_params[:] = (*h.accel_bias_s, self.params.base_heading_deg * DEG, T, *k, float(h.height),
                                 h.north_drift, *h.gyro_drift_s, *torque_n)
        self._start()

    def _start(self) -> None:
        h = self._handoff
        s = self.state
        accepted = s[nk.N_ACCEPTED]
        s[:] = 0.0
        s[nk.N_LAT:nk.N_DA + 1] = (float(h.lat), float(h.lon), float(h.height), *(float(v) for v in h.velocity_n),
                                   0.0)  # δa: the vertical loop's integral state [m/s²]
        s[nk.N_ACCEPTED] = accepted
        self._t_last_ns: int | None = None
        self._t0_ns: int | None = None

    lat = slot(nk.N_LAT, doc="latitude L [rad]")
    lon = slot(nk.N_LON, doc="longitude λ [rad]")
    height = slot(nk.N_H, doc="height h [m]")
    vn = slot(nk.N_VN, doc="north velocity [m/s]")
    ve = slot(nk.N_VE, doc="east velocity [m/s]")
    vd = slot(nk.N_VD, doc="down velocity [m/s]")
    accepted = slot(nk.N_ACCEPTED, int, "samples integrated")

    @property
    def h_ref(self) -> float:
        """Reference height of the vertical channel [m]."""
        return float(self.kernel_params[nk.Q_H_REF])

    def reset(self, reason: str) -> None:
        """Restart from the hand-off values; ``reason`` goes to ``reset_reasons``."""
        self.resets += 1
        self.reset_reasons.append(str(reason))
        self._start()

    def set_reference_height(self, h_ref: float) -> None:
        """Reference altitude [m] of the vertical channel (an external altimeter)."""
        h_ref = float(h_ref)
        if not math.isfinite(h_ref):
            raise ValueError(f"reference height must be finite, got {h_ref!r}")
        self.kernel_params[nk.Q_H_REF] = h_ref

    # -- input checks ----------------------------------------------------------------------
    def _admit(self, t_ns, f_s, theta_a) -> tuple[float, float, float, float] | Fed:
        """(f_x, f_y, f_z, θ_a) as floats, or why the sample is refused (counted)."""
        try:
            f = [float(v) for v in f_s]
            t_ok = math.isfinite(float(t_ns))
        except (TypeError, ValueError):
            self.rejected_nonfinite += 1
            return _NONFINITE
        if len(f) != 3 or not t_ok or not all(math.isfinite(v) for v in f):
            self.rejected_nonfinite += 1
            return _NONFINITE
        if theta_a is None:
            self.rejected_no_resolver += 1
            return _NO_RESOLVER
        try:
            a = float(theta_a)
        except (TypeError, ValueError):
            a = math.nan
        if not math.isfinite(a):
            self.rejected_nonfinite += 1
            return _NONFINITE
        return f[0], f[1], f[2], a

    # -- the step ----------------------------------------------------------------------------
    def step(self, t_ns: int, f_s: Sequence[float], theta_a: float | None) -> Fed:
        """One sample: specific force ``f_s`` (3,) [m/s²] in platform axes, azimuth angle
        ``theta_a`` [rad] of the ``azimuth_source`` (resolver θ_a or servo φz; None when the
        sample is missing or stale) at stamp ``t_ns`` [int ns]. Returns what it did
        (:class:`~gimbal_kinematics.maths.outcome.Fed`): the :class:`NavigatorOutput`, or
        why the sample was refused (counted)."""
        sample = self._admit(t_ns, f_s, theta_a)
        if isinstance(sample, Fed):
            return sample
        t_ns = int(t_ns)
        first = self._t_last_ns is None
        if first:
            self._t0_ns = t_ns
        dt = 0.0 if first else (t_ns - self._t_last_ns) * 1e-9
        self._t_last_ns = t_ns
        s = self.state
        nk.navigator_step(s, self.kernel_params, first, dt, (t_ns - self._t0_ns) * 1e-9, sample[0], sample[1],
                          sample[2], sample[3])
        return Fed(True, output=NavigatorOutput(t_ns, (self.vn, self.ve, self.vd), self.lat, self.lon, self.height,
                                                tuple(s[nk.N_CMD_N:nk.N_CMD_D + 1].tolist()), float(s[nk.N_PSI]),
                                                bool(s[nk.N_TORQUING])))

    # -- outputs -----------------------------------------------------------------------------
    def counters(self, dropped_stamps: int = 0) -> dict[str, int]:
        """The counters by name (for /diagnostics); ``dropped_stamps``: the stamps the input
        policy dropped as repeated or late."""
        return {"accepted": self.accepted, "rejected_nonfinite": self.rejected_nonfinite,
                "rejected_out_of_order": dropped_stamps,
                "rejected_no_resolver": self.rejected_no_resolver, "resets": self.resets}
