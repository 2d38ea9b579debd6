"""Free-gyro positioning and heading (paper 4, docs/spec.md §3.4): message-driven core.

Inputs (each with its message time stamp t [s]):

* :meth:`FreeGyroPositioning.on_level` — roll, pitch [rad] of the vertical reference;
* :meth:`FreeGyroPositioning.on_spin_axes` — the two free-gyro spin axes read out in the
  body FRD frame (unit vectors, the free gyros' pickoff read-outs);
* :meth:`FreeGyroPositioning.on_body_rates` — body gyro triad ω_ib^b [rad/s] (step average);
* :meth:`FreeGyroPositioning.on_velocity` — optional NED ground velocity [m/s] (transport
  rate removal for the earth-rate heading; default at rest).

Mechanisation (paper 4 Figs. 3–4, re-derived)
---------------------------------------------
Levelling: l is the heading-only frame, u_l = rot2(pitch)ᵀ rot1(roll)ᵀ u_b. In l the nadir
angle is θ = atan2(√(u_lx² + u_ly²), u_lz) — heading-free, so the fix needs no heading —
and the azimuth of the gyro vector from the ship's head is ζ = atan2(u_ly, u_lx) (Fig. 4).

Nadir-angle integration (Fig. 4, θ = ∫ω_θ dt): an inertially fixed spin axis tilts relative
to the local vertical at ω_θ = ω_in,N sin α − ω_in,E cos α (Ω cos φ sin α at rest; paper
eq. 6). Over a fix window of ``fix_interval_s`` the core integrates every sample into a
least-squares line θ(t) = θ̄ + ω_θ (t − t̄) per gyro: θ̄ at the window's mean time t̄ has
σ_θ = σ_pickoff/√n and is uncorrelated with the slope, and the slope is the measured
tilting rate ω_θ of Fig. 4 (reported, and a consistency check of the fix against eq. 6).
With angle pickoffs the integral of the measured motion telescopes to the read-out angle,
so integrating is the same as fitting the read-outs; the line absorbs the ≤ 15″/min drift of
θ within the window without any knowledge of the position.

Fix (eq. 1): ``gimbal_kinematics.maths.free_gyro.position_fix`` at t̄ with the two integrated
nadir angles; the mirror-image branch is chosen by the sense of Δα = α_b − α_a, which the
ship measures as ζ_b − ζ_a (heading cancels). Geometry (eq. 31–38):
``fix_geometry`` gives FDOP = √2/|sin Δα| and the covariance FDOP-scaled by σ_θ in north/
east metres (``FixGeometry.covariance_ne_m``). The fix is withheld, with ``status =
'degenerate'`` and a reason, when the gyro vectors are (anti)parallel, the nadir circles are
tangent or do not intersect, a gyro vector is vertical, or FDOP exceeds ``max_fdop``.

Heading, two ways:

* free-gyro heading (Fig. 4): ψ = α − ζ with α from eq. 2 at the fix and ζ̄ the window's
  circular mean, both gyros combined with weights sin²θ (ζ noise is σ/sin θ); this is the
  window-mean heading. Its σ propagates the horizontal pickoff noise and the fix error
  (α depends on the position through eq. 2).
* earth-rate heading (Fig. 3, eq. 3–4): over ``heading_window_s`` the levelled triad
  rate is averaged after removing the ship's level rotation rates, whose levelled
  components are (cos θ φ̇, θ̇) for 3-2-1 angles (exact; they telescope into the roll and
  pitch changes over the window, so oscillation cancels) and the transport rate
  rot3(ψ) ω_en^n (ψ the window's own heading, found by fixed-point iteration, φ from the
  latest fix, the velocity from :meth:`on_velocity`). What is left is rot3(ψ) ω_ie^n: ψ = atan2(−ω_ly, ω_lx)
  (``heading_from_earth_rate``), σ_ψ = (N_triad/√T)/(Ω cos φ) — paper eq. 29 for white
  triad noise. Yaw oscillation within the window averages to the mean heading.

All angles rad, rates rad/s, times s, distances m. Non-finite inputs and non-unit spin axes
are rejected and counted. Stamps come checked and in order: the node's input policy
(:func:`gimbal_kinematics.timing.input_policy.synced_policy`) refuses late and repeated read-outs
and, on a clock jump back, calls :meth:`FreeGyroPositioning.reset`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.earth import OMEGA_IE, transport_rate_n
from gimbal_kinematics.maths.free_gyro import (
    FixTolerances,
    fix_geometry,
    gyro_azimuth,
    heading_from_earth_rate,
    position_fix,
    spin_axes_for_site_deg,
    unit_vector,
)
from gimbal_kinematics.maths.units import ARCSEC, DEG_RT_H
from gimbal_kinematics.maths.outcome import Fed, refused
from gimbal_kinematics.maths.validate import finite, nonneg_finite, of_type, positive
from gimbal_kinematics.params.table import ParameterError

from .core_counters import CoreCounters

_NAN = float("nan")
_TRANSPORT_ITERATIONS = 4  # contraction ≤ 0.05 at 20 m/s: the heading to 1e-5 of its first error


@dataclass(frozen=True)
class FreeGyroPositioningParams:
    """Parameters of the free-gyro positioning core (validated, immutable).

    Attributes:
        u_a_i, u_b_i: the gyros' inertial spin axes (unit, not parallel), inertial frame of
            ``gimbal_kinematics.maths.free_gyro`` (x to Greenwich at t = 0, z the earth's axis).
        nadir_noise_arcsec: σ of one read-out nadir angle [″] (pickoff noise), for the fix σ.
        fix_interval_s: nadir integration window per fix [s].
        min_samples: fewest read-outs in a window for a fix (≥ 3: a line and its residual).
        heading_window_s: earth-rate heading averaging window [s].
        triad_arw_deg_rt_h: triad angle random walk [°/√h], for the earth-rate heading σ.
        spin_rate_arw_deg_rt_h: angle random walk [°/√h] of the spin-axis rate sensors, whose
            integrated outputs the read-outs are, integrated since ``spin_reference_time_s`` [s]:
            the fix σ adds the window mean's random walk, N² (t̄ − t_ref − T/6) (0: pickoffs).
        max_fdop: FDOP above which the geometry is reported degenerate and no fix is given.
        min_sin_gyro_separation, min_sin_crossing_angle: ``FixTolerances`` of the fix.
        height_m: height used for the metric covariance [m].
        max_level_age_s: oldest vertical-reference sample [s] used to level a read-out.
    """

    u_a_i: tuple[float, float, float]
    u_b_i: tuple[float, float, float]
    nadir_noise_arcsec: float = 5.0
    fix_interval_s: float = 10.0
    min_samples: int = 5
    heading_window_s: float = 60.0
    triad_arw_deg_rt_h: float = 0.002
    spin_rate_arw_deg_rt_h: float = 0.0
    spin_reference_time_s: float = 0.0
    max_fdop: float = 20.0
    min_sin_gyro_separation: float = 1e-6
    min_sin_crossing_angle: float = 1e-6
    height_m: float = 0.0
    max_level_age_s: float = 0.2
    omega_ie_rad_s: float = OMEGA_IE

    def __post_init__(self) -> None:
        a = unit_vector(self.u_a_i, "u_a_i")
        b = unit_vector(self.u_b_i, "u_b_i")
        object.__setattr__(self, "u_a_i", a)
        object.__setattr__(self, "u_b_i", b)
        for name in ("nadir_noise_arcsec", "fix_interval_s", "heading_window_s", "triad_arw_deg_rt_h",
                     "max_level_age_s", "omega_ie_rad_s"):
            positive(name, getattr(self, name))
        if positive("max_fdop", self.max_fdop) < math.sqrt(2.0):
            raise ValueError(f"max_fdop must be >= √2 (the best two-gyro FDOP), got {self.max_fdop}")
        if not isinstance(self.min_samples, int) or isinstance(self.min_samples, bool) or self.min_samples < 3:
            raise ValueError(f"min_samples must be an int >= 3, got {self.min_samples!r}")
        for name in ("min_sin_gyro_separation", "min_sin_crossing_angle"):
            v = finite(name, getattr(self, name))
            if not 0.0 < v < 1.0:
                raise ValueError(f"{name} must be in (0, 1), got {v}")
        finite("height_m", self.height_m)
        nonneg_finite("spin_rate_arw_deg_rt_h", self.spin_rate_arw_deg_rt_h)
        finite("spin_reference_time_s", self.spin_reference_time_s)
        cx = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        if math.sqrt(sum(c * c for c in cx)) < self.min_sin_gyro_separation:
            raise ValueError("u_b_i must not be parallel or antiparallel to u_a_i (the nadir circles "
                             "would be concentric: no fix anywhere)")

    @property
    def tolerances(self) -> FixTolerances:
        return FixTolerances(self.min_sin_gyro_separation, self.min_sin_crossing_angle)

    @classmethod
    def from_values(cls, v: dict) -> FreeGyroPositioningParams:
        """The parameters from a ``free_gyro_positioning`` node's values (name -> value, as
        declared in :mod:`.free_gyro_positioning_params`): the spin axes from the angles they
        were set to at a reference site and time; :class:`ParameterError` names the
        parameter refused."""
        try:
            u_a, u_b = spin_axes_for_site_deg(v["spin_reference_lat_deg"], v["spin_reference_lon_deg"],
                                              v["spin_nadir_deg"], v["spin_azimuth_deg"], v["spin_reference_time_s"],
                                              names=("spin_nadir_deg", "spin_azimuth_deg"))
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc
        try:
            return cls(
                u_a, u_b, nadir_noise_arcsec=v["nadir_noise_arcsec"], fix_interval_s=v["fix_interval_s"],
                min_samples=v["min_samples"], heading_window_s=v["heading_window_s"],
                triad_arw_deg_rt_h=v["triad_arw_deg_rt_h"], max_fdop=v["max_fdop"], height_m=v["height_m"],
                spin_rate_arw_deg_rt_h=v["spin_rate_arw_deg_rt_h"], spin_reference_time_s=v["spin_reference_time_s"])
        except ValueError as exc:
            text = str(exc)
            if "u_a_i" in text or "u_b_i" in text:  # the axes are the spin angles' doing
                text = f"parameters 'spin_nadir_deg', 'spin_azimuth_deg': {text}"
            raise ParameterError(text) from exc


class FreeGyroFix(NamedTuple):
    """One fix window's result, stamped at the window's mean time ``t`` [s].

    ``status``: 'ok' or 'degenerate' (then ``lat``, ``lon``, ``heading``, ``cov_ne_m`` are
    NaN and ``reason`` says why). ``lat``, ``lon`` [rad]; ``cov_ne_m`` (2, 2) north/east
    covariance [m²] = FDOP-scaled σ_θ²; ``fdop`` (NaN if not computable); ``nadir`` (2,)
    integrated nadir angles (θ_a, θ_b) [rad], ``nadir_sigma`` [rad]; ``tilt_rate`` (2,) the
    measured dθ/dt [rad/s] (Fig. 4's ω_θ); ``crossing_angle`` Δα = ζ_b − ζ_a [rad];
    ``heading`` free-gyro window-mean heading [rad] ± ``heading_sigma``;
    ``heading_earth_rate`` [rad] ± ``heading_earth_rate_sigma`` from the latest completed
    earth-rate window, stamped ``heading_earth_rate_t`` (NaN until one completes);
    ``n_samples`` read-outs integrated.
    """

    t: float
    status: str
    reason: str
    lat: float
    lon: float
    cov_ne_m: np.ndarray
    fdop: float
    nadir: np.ndarray
    nadir_sigma: float
    tilt_rate: np.ndarray
    crossing_angle: float
    heading: float
    heading_sigma: float
    heading_earth_rate: float
    heading_earth_rate_sigma: float
    heading_earth_rate_t: float
    n_samples: int

    @property
    def valid(self) -> bool:
        return self.status == "ok"


def navsat_covariance_enu(cov_ne_m: np.ndarray, vertical_variance_m2: float) -> tuple[float, ...]:
    """``sensor_msgs/NavSatFix.position_covariance`` (9, row-major, ENU [m²]) from the
    north/east covariance (2, 2) [m²]; the free gyros do not observe height, so the caller
    supplies its variance (e.g. from the height source)."""
    c = np.asarray(cov_ne_m, dtype=float)
    if c.shape != (2, 2):
        raise ValueError(f"cov_ne_m must have shape (2, 2), got {c.shape}")
    nn, ne, ee = float(c[0, 0]), float(c[0, 1]), float(c[1, 1])
    vv = float(vertical_variance_m2)
    return (ee, ne, 0.0, ne, nn, 0.0, 0.0, 0.0, vv)


def _level(x: float, y: float, z: float, cr: float, sr: float, cp: float, sp: float) -> tuple[float, float, float]:
    """rot2(pitch)ᵀ rot1(roll)ᵀ v: body FRD vector in the heading-only frame."""
    vy = cr * y - sr * z
    vz = sr * y + cr * z
    return cp * x + sp * vz, vy, -sp * x + cp * vz


_USED = Fed(True)
_NONFINITE = refused("non-finite sample")
_NOT_UNIT = refused("spin axis not a unit vector")
_NO_LEVEL = refused("no vertical reference yet")
_STALE_LEVEL = refused("vertical reference older than max_level_age_s")


@dataclass
class _Counters(CoreCounters):
    spin_accepted: int = 0
    rates_accepted: int = 0
    rejected_not_unit: int = 0
    rejected_no_level: int = 0
    rejected_stale_level: int = 0
    fixes: int = 0
    degenerate: int = 0


class FreeGyroPositioning:
    """Free-gyro fix and heading core (module docstring). ROS-free, message-driven."""

    def __init__(self, params: FreeGyroPositioningParams) -> None:
        of_type("params", params, FreeGyroPositioningParams)
        self.params = params
        self._sigma_pick = params.nadir_noise_arcsec * ARCSEC
        self._triad_arw = params.triad_arw_deg_rt_h * DEG_RT_H
        self.counters = _Counters()
        self.last_fix: FreeGyroFix | None = None
        self._restart()

    # -- state ---------------------------------------------------------------------------
    def _restart(self) -> None:
        self._level_sample: tuple[float, float, float] | None = None  # (t, roll, pitch)
        self._v_n: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._lat: float | None = None
        self._er = (_NAN, _NAN, _NAN)  # (heading, σ, t) of the latest earth-rate window
        self._clear_window()
        self._clear_heading_window()

    def _clear_window(self) -> None:
        self._w_t0: float | None = None
        self._w_n = 0
        # Σ τ, Σ τ², Σθa, Σθb, Σ τθa, Σ τθb, Σ cos ζa, Σ sin ζa, Σ cos ζb, Σ sin ζb, Σ cos Δζ, Σ sin Δζ
        self._w = [0.0] * 12

    def _clear_heading_window(self) -> None:
        self._h_prev: tuple[float, float, float] | None = None  # (t, roll, pitch) at last rate
        self._h = [0.0, 0.0, 0.0, 0.0, 0.0]  # Σ lx dt, Σ ly dt, Σ cosθ dφ, Σ dθ, T

    def reset(self, reason: str) -> None:
        """Drop all windows and inputs; ``reason`` is recorded."""
        self.counters.count_reset(reason)
        self._restart()

    def _stamp(self, t: object) -> float | None:
        """A finite time stamp [s]; None (counted) if it is not."""
        try:
            t = float(t)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            self.counters.rejected_nonfinite += 1
            return None
        if not math.isfinite(t):
            self.counters.rejected_nonfinite += 1
            return None
        return t

    def _checked(self, t: object, values: Sequence[float], n: int) -> tuple[float, tuple[float, ...]] | None:
        """(stamp, the first ``n`` values) as finite floats; None (counted) when a value is
        missing or not finite, or the stamp is not finite."""
        try:
            v = tuple(float(values[i]) for i in range(n))
        except (TypeError, ValueError, IndexError):
            v = None
        if v is None or not all(math.isfinite(c) for c in v):
            self.counters.rejected_nonfinite += 1
            return None
        ts = self._stamp(t)
        return None if ts is None else (ts, v)

    def _level_at(self, t: float) -> tuple[float, float] | Fed:
        """(roll, pitch) [rad] of the vertical reference at ``t``, or why there is none (counted)."""
        lv = self._level_sample
        if lv is None:
            self.counters.rejected_no_level += 1
            return _NO_LEVEL
        if abs(t - lv[0]) > self.params.max_level_age_s:
            self.counters.rejected_stale_level += 1
            return _STALE_LEVEL
        return lv[1], lv[2]

    # -- inputs --------------------------------------------------------------------------
    def on_level(self, t: float, roll: float, pitch: float) -> Fed:
        """Vertical reference: roll, pitch [rad] (3-2-1 Euler angles of the body); each
        ``on_*`` returns what it did (:class:`~gimbal_kinematics.maths.outcome.Fed`)."""
        sample = self._checked(t, (roll, pitch), 2)
        if sample is None:
            return _NONFINITE
        self._level_sample = (sample[0], *sample[1])
        return _USED

    def on_velocity(self, t: float, v_n: Sequence[float]) -> Fed:
        """NED ground velocity [m/s] (3,), for the transport rate of the earth-rate heading."""
        sample = self._checked(t, v_n, 3)
        if sample is None:
            return _NONFINITE
        self._v_n = sample[1]
        return _USED

    def on_body_rates(self, t: float, omega_ib_b: Sequence[float]) -> Fed:
        """Body triad step-average rate ω_ib^b (3,) [rad/s] over the interval ending at t."""
        sample = self._checked(t, omega_ib_b, 3)
        if sample is None:
            return _NONFINITE
        ts, (wx, wy, wz) = sample
        lv = self._level_at(ts)
        if isinstance(lv, Fed):
            return lv
        self.counters.rates_accepted += 1
        roll, pitch = lv
        prev = self._h_prev
        self._h_prev = (ts, roll, pitch)
        if prev is None:
            return _USED  # opens the window: the rate covers an interval before it
        dt = ts - prev[0]
        rm, pm = 0.5 * (roll + prev[1]), 0.5 * (pitch + prev[2])
        lx, ly, _ = _level(wx, wy, wz, math.cos(rm), math.sin(rm), math.cos(pm), math.sin(pm))
        h = self._h
        h[0] += lx * dt
        h[1] += ly * dt
        h[2] += math.cos(pm) * (roll - prev[1])
        h[3] += pitch - prev[2]
        h[4] += dt
        if h[4] >= self.params.heading_window_s:
            self._close_heading_window(ts)
        return _USED

    def _close_heading_window(self, t: float) -> None:
        sx, sy, sphi, stheta, T = self._h
        wx, wy = (sx - sphi) / T, (sy - stheta) / T
        try:
            psi = heading_from_earth_rate((wx, wy, 0.0))
            if self._lat is not None and any(self._v_n):
                # transport rate rot3(ψ) ω_en^n at the window's own mean heading ψ (the latest
                # fix's latitude): ψ = heading(ω − rot3(ψ) ω_en) is a contraction by
                # |ω_en|/(Ω cos φ) (3 % at 10 m/s, 35°), iterated from the uncorrected heading. A
                # fix window's heading instead would be 10 s of a yawing ship, off the mean by ~1°.
                w_en = transport_rate_n(self._lat, self.params.height_m, np.array(self._v_n))
                for _ in range(_TRANSPORT_ITERATIONS):
                    c, s = math.cos(psi), math.sin(psi)
                    lx, ly = wx - (c * w_en[0] + s * w_en[1]), wy - (-s * w_en[0] + c * w_en[1])
                    psi = heading_from_earth_rate((lx, ly, 0.0))
                wx, wy = lx, ly
            sigma = self._triad_arw / math.sqrt(T) / math.hypot(wx, wy)
        except ValueError:
            psi, sigma = _NAN, _NAN
        self._er = (psi, sigma, t - 0.5 * T)
        self._clear_heading_window()
        self._h_prev = (t, *self._level_sample[1:]) if self._level_sample is not None else None

    def on_spin_axes(self, t: float, spin_a_b: Sequence[float], spin_b_b: Sequence[float]) -> Fed:
        """Read-out of both spin axes in body FRD (unit (3,) each) at ``t`` [s]. Returns what
        it did, its ``output`` the :class:`FreeGyroFix` when this sample completes a fix
        window."""
        a = self._checked(t, spin_a_b, 3)
        b = None if a is None else self._checked(t, spin_b_b, 3)
        if b is None:
            return _NONFINITE
        (ts, (ax, ay, az)), (bx, by, bz) = a, b[1]
        na, nb = math.sqrt(ax * ax + ay * ay + az * az), math.sqrt(bx * bx + by * by + bz * bz)
        if abs(na - 1.0) > 1e-3 or abs(nb - 1.0) > 1e-3:
            self.counters.rejected_not_unit += 1
            return _NOT_UNIT
        lv = self._level_at(ts)
        if isinstance(lv, Fed):
            return lv
        self.counters.spin_accepted += 1
        cr, sr, cp, sp = math.cos(lv[0]), math.sin(lv[0]), math.cos(lv[1]), math.sin(lv[1])
        lax, lay, laz = _level(ax / na, ay / na, az / na, cr, sr, cp, sp)
        lbx, lby, lbz = _level(bx / nb, by / nb, bz / nb, cr, sr, cp, sp)
        ha, hb = math.hypot(lax, lay), math.hypot(lbx, lby)
        th_a, th_b = math.atan2(ha, laz), math.atan2(hb, lbz)
        if self._w_t0 is None:
            self._w_t0 = ts
        tau = ts - self._w_t0
        w = self._w
        w[0] += tau
        w[1] += tau * tau
        w[2] += th_a
        w[3] += th_b
        w[4] += tau * th_a
        w[5] += tau * th_b
        if ha > 0.0:
            w[6] += lax / ha
            w[7] += lay / ha
        if hb > 0.0:
            w[8] += lbx / hb
            w[9] += lby / hb
        if ha > 0.0 and hb > 0.0:
            # Δζ = ζb − ζa through its cosine and sine (no branch cut)
            w[10] += (lax * lbx + lay * lby) / (ha * hb)
            w[11] += (lax * lby - lay * lbx) / (ha * hb)
        self._w_n += 1
        n = self._w_n
        # n read-outs cover n sample intervals (≈ τ n/(n−1)): close when they span the interval
        if n < self.params.min_samples or tau * n < (self.params.fix_interval_s - 1e-9) * (n - 1):
            return _USED
        fix = self._close_window()
        self._clear_window()
        return Fed(True, output=fix)

    # -- fix -----------------------------------------------------------------------------
    def _close_window(self) -> FreeGyroFix:
        p = self.params
        n = self._w_n
        w = self._w
        tbar = w[0] / n
        stt = w[1] - n * tbar * tbar
        nadir = np.array([w[2] / n, w[3] / n])
        slope = np.array([(w[4] - tbar * w[2]) / stt, (w[5] - tbar * w[3]) / stt]) if stt > 0.0 else np.full(2, _NAN)
        t_fix = self._w_t0 + tbar
        sigma_theta = self._sigma_pick / math.sqrt(n)
        if p.spin_rate_arw_deg_rt_h > 0.0:   # the integrated rate sensors' random walk, window mean
            walk = max(t_fix - p.spin_reference_time_s - math.sqrt(max(stt, 0.0) / (3.0 * n)), 0.0)
            sigma_theta = math.sqrt(sigma_theta**2 + (p.spin_rate_arw_deg_rt_h * DEG_RT_H) ** 2 * walk)
        crossing = math.atan2(w[11], w[10])
        zeta = (math.atan2(w[7], w[6]), math.atan2(w[9], w[8]))
        er_psi, er_sigma, er_t = self._er
        nan2 = np.full((2, 2), _NAN)

        def degenerate(reason: str, fdop: float = _NAN) -> FreeGyroFix:
            self.counters.degenerate += 1
            return FreeGyroFix(t_fix, "degenerate", reason, _NAN, _NAN, nan2, fdop, nadir, sigma_theta, slope,
                               crossing, _NAN, _NAN, er_psi, er_sigma, er_t, n)

        sense = math.sin(crossing)
        if sense == 0.0:
            fix = degenerate("nadir circles are tangent: the gyro azimuths coincide or are opposite")
        else:
            try:
                lat, lon = position_fix(p.u_a_i, p.u_b_i, float(nadir[0]), float(nadir[1]), t_fix,
                                        azimuth_sense=sense, tolerances=p.tolerances, omega_ie=p.omega_ie_rad_s)
                geom = fix_geometry(p.u_a_i, p.u_b_i, lat, lon, t_fix, p.tolerances, p.omega_ie_rad_s)
            except ValueError as exc:
                fix = degenerate(str(exc))
            else:
                if geom.fdop > p.max_fdop:
                    fix = degenerate(f"FDOP {geom.fdop:.3g} exceeds max_fdop {p.max_fdop:g} "
                                     "(nadir circles nearly tangent)", geom.fdop)
                else:
                    psi, psi_sigma = self._free_gyro_heading(lat, lon, t_fix, nadir, zeta, n,
                                                             geom.Q_latlon * sigma_theta**2)
                    self._lat = lat
                    self.counters.fixes += 1
                    fix = FreeGyroFix(t_fix, "ok", "", lat, lon, geom.covariance_ne_m(sigma_theta, p.height_m),
                                      geom.fdop, nadir, sigma_theta, slope, crossing, psi, psi_sigma,
                                      er_psi, er_sigma, er_t, n)
        self.last_fix = fix
        return fix

    def _free_gyro_heading(self, lat: float, lon: float, t: float, nadir: np.ndarray,
                           zeta: tuple[float, float], n: int, cov_latlon: np.ndarray) -> tuple[float, float]:
        """ψ = α − ζ̄ per gyro, combined with weights w = sin²θ (Fig. 4).

        σ: δψ = Σ w_k (J_k δx − δζ_k)/Σ w_k, with δx = (δφ, δλ) the fix error (covariance
        ``cov_latlon``), J_k = ∂α_k/∂(φ, λ) (central differences of eq. 2) and δζ_k the
        horizontal pickoff noise, σ²/(n sin²θ_k), independent of the nadir (vertical) part.
        """
        p = self.params
        sx = sy = wsum = 0.0
        J = np.zeros(2)
        var_z = 0.0
        h = 1e-6
        for u, th, z in ((p.u_a_i, nadir[0], zeta[0]), (p.u_b_i, nadir[1], zeta[1])):
            s2 = math.sin(th) ** 2
            if s2 < 1e-12:
                continue
            alpha = gyro_azimuth(u, lat, lon, t, p.omega_ie_rad_s)
            psi_k = alpha - z
            sx += s2 * math.cos(psi_k)
            sy += s2 * math.sin(psi_k)
            wsum += s2
            lat_p, lat_m = min(lat + h, math.pi / 2), max(lat - h, -math.pi / 2)
            J[0] += s2 * math.remainder(gyro_azimuth(u, lat_p, lon, t, p.omega_ie_rad_s)
                                        - gyro_azimuth(u, lat_m, lon, t, p.omega_ie_rad_s), math.tau) / (lat_p - lat_m)
            J[1] += s2 * math.remainder(gyro_azimuth(u, lat, lon + h, t, p.omega_ie_rad_s)
                                        - gyro_azimuth(u, lat, lon - h, t, p.omega_ie_rad_s), math.tau) / (2 * h)
            var_z += s2 * s2 * self._sigma_pick**2 / (n * s2)
        if wsum == 0.0:
            return _NAN, _NAN
        var = (float(J @ cov_latlon @ J) + var_z) / (wsum * wsum)
        return math.atan2(sy, sx), math.sqrt(var)
