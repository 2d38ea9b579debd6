"""Rotation-modulated fine alignment of a platform INS on a static base (paper 3, docs/spec.md §3.3).

The platform (stable element ``s``) is held level by its servo and turned back and forth
about the local vertical; the 8-state recursive least squares (RLS) of paper 3 estimates
its initial misalignment, the north drift and the level accelerometer biases and gyro drifts
from the level accelerometers and the azimuth gimbal angle.

Conventions (re-derived; the paper's OCR'd equations are not copied)
-------------------------------------------------------------------
* Navigation frame n = NED. The platform azimuth ψ is the azimuth joint angle θ_a of
  ``gimbal_kinematics.maths.four_gimbal``: ``C_sn,ideal = rot3(ψ)``, ψ about NED *down*. Paper 3's
  φz is about ENU *up*, so **φz(paper) = −ψ**. The platform axes x, y, z are the sim's
  (x = north, y = east, z = down at ψ = 0; paper 3's x is east): ∇x, ∇y, ε_x, ε_y below are
  resolved in these axes.
* Misalignment φ: the rotation vector that takes the ideal platform to the true one,
  ``C_ns,true = exp([φ×]) C_ns,ideal``. Its components are reported in ENU,
  (δφE, δφN, δφU) = (φ_2, φ_1, −φ_3) of the NED components — the paper's state order.
  δφU > 0 is a counter-clockwise (seen from above) azimuth error.
* Units: rad, rad/s, m/s², s; g is WGS-84 normal gravity at the latitude unless given;
  Ω = 7.292115e-5 rad/s, ω_N = Ω cos L, ω_U = Ω sin L.

Model (paper eqs. 5–17)
-----------------------
Platform error dynamics (psi-angle form, static base; the platform precesses at its commanded
rate plus the gyro drift ε_s, and the NED frame turns at ω_ie): φ̇ = −ω_ie × φ + ε_n with
ε_n = C_ns ε_s + ε_nav. In ENU components that is paper eq. 5:

    δφ̇E = ω_U δφN − ω_N δφU + εE,   δφ̇N = −ω_U δφE + εN,   δφ̇U = ω_N δφE + εU.

Over an alignment of T ≪ 1/Ω (paper eq. 7) it integrates to first order (eq. 8, 12):

    δφE(t) = δφE0 + (ω_U δφN0 − ω_N δφU0) t + ∫εE dt
    δφN(t) = δφN0 − ω_U δφE0 t + ∫εN dt

The platform gyro drifts ε_x, ε_y are fixed in s and are *modulated* by the rotation:
ε_n = rot3(ψ)ᵀ ε_s gives εN = cos ψ ε_x − sin ψ ε_y, εE = sin ψ ε_x + cos ψ ε_y (eq. 11), so
∫εN dt = I_c ε_x − I_s ε_y and ∫εE dt = I_s ε_x + I_c ε_y with I_c = ∫cos ψ dt,
I_s = ∫sin ψ dt. For ψ = ω_r t these are paper eq. 12's sin φz/ω_r and (1 − cos φz)/ω_r
terms; this implementation integrates the *measured* ψ(t) instead, which stays exact for the
bidirectional schedule (whose return leg has ψ̇ = −ω_r) and for reversal transients. The
part of the drift that is fixed in n (torquer and command errors) is the north drift ε_N
state; its east counterpart is unobservable (it is indistinguishable from ω_N δφU0, the
classical gyrocompass limit δφU error = −εE/ω_N) and is not a state.

Accelerometers (eq. 9, 17): with f_n = (0, 0, −g) at rest, f_s = C_sn,ideal (I − [φ×]) f_n +
∇_s, so the level specific force resolved into the ideal level frame,
f_h = rot3(ψ)ᵀ f_s, is f_N = g δφE + ∇N and f_E = −g δφN + ∇E, with ∇N = cos ψ ∇x − sin ψ ∇y
and ∇E = sin ψ ∇x + cos ψ ∇y. The measurement Z = (f_N/g, −f_E/g) = (δφE + ∇N/g,
δφN − ∇E/g). At fixed ψ the bias is a constant indistinguishable from the initial tilt
(eq. 9); the rotation modulates it and separates the two (eq. 10).

Hence Z = H X with X = [δφE0, δφN0, δφU0, ε_N, ∇x, ∇y, ε_x, ε_y] (eq. 15) and (eq. 16)

    H = [[ 1 − Ω²t²/2,  ω_U t,            −ω_N t,        ω_U t²/2,  cos ψ/g, −sin ψ/g, I_s,  I_c],
         [−ω_U t,        1 − ω_U² t²/2,   ω_N ω_U t²/2,  t,        −sin ψ/g, −cos ψ/g, I_c, −I_s]]

with t measured from the alignment start (the first accepted accelerometer sample).
Mapping to the paper: its platform axes are x_p = our y, y_p = our x (z_p = up = −z) and
φz = −ψ; with ψ = −ω_r t our rows then reproduce paper eq. 13 term by term (e.g. row E's
bias terms become (sin φz ∇x_p + cos φz ∇y_p)/g and its drift terms
(sin φz ε_x_p + (cos φz − 1) ε_y_p)/ω_r). The OCR'd eq. 16 swaps the accelerometer
columns relative to eq. 13; this implementation follows eq. 13, i.e. the physics. The
t² entries are the second-order terms ½ ω×(ω×φ0) t² − ½ ω×ε t² of the exact solution
(paper eq. 6) that the paper's eq. 8 drops; ω_N ω_U δφU0 t²/2 is 0.5″ after 10 min with
δφU0 = 17′ and would bias ε_N by ≈0.0016°/h if left out. Still neglected: (Ωt)³ terms,
the unmodelled azimuth drift ε_U (it adds −ω_N ε_U t²/2 to δφE and biases δφU0 by about
ε_U T/2, ≈9″ for 0.03°/h over T = 600 s) and products φ·ε of the modulated drifts.

Estimator and scaling
---------------------
Paper eq. 18 is the RLS P⁺ = P − P Hᵀ (I + H P Hᵀ)⁻¹ H P with X0 = 0 and P0 = I: a Kalman
update with unit measurement noise and unit prior. Taken literally in SI units that prior is
1 rad, 1 rad/s and 1 m/s², and the unit measurement weight makes the prior worth as much as
one sample — over 10 min the prior then shrinks δφU0 toward zero (its column ω_N t is only
~0.03). So the filter runs in *normalised* coordinates where eq. 18 holds exactly:
ξ = X / s with per-state scales s (``*_scale_*`` fields: a generous a-priori size of each
error) so that P0 = I means "each error is about its scale", and the measurement is whitened
by its noise σ_z so that R = I. The update is ``kalman.joseph_update``. Accelerometer samples
(any rate) are averaged over blocks of ``block_s``: Z and H are both linear in the samples, so
mean(Z) = mean(H) X + mean(V) exactly, with var(mean V) = (N_a/g)² Σ(1/Δt_k)/n² for white
noise of density N_a; one 2-row update per block keeps the cost per raw sample to a few µs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.earth import OMEGA_IE, normal_gravity
from gimbal_kinematics.maths.units import ARCMIN, ARCSEC, DEG_H, UG
from gimbal_kinematics.maths.validate import finite, of_type, positive
from gimbal_kinematics.params.table import ParameterError

from gimbal_kinematics.maths.kalman import check_state, joseph_update, symmetrize
from gimbal_kinematics.maths.outcome import Fed, refused

from .core_counters import CoreCounters

#: State order (paper eq. 15).
STATE_NAMES = ("dphi_E0", "dphi_N0", "dphi_U0", "eps_N", "bias_x", "bias_y", "eps_x", "eps_y")
N_STATES = len(STATE_NAMES)
#: Indices and slices of X: the initial misalignment (δφE0, δφN0, δφU0), its tilt part
#: (δφE0, δφN0) and azimuth δφU0; the north drift ε_N; the accelerometer biases (∇x, ∇y);
#: the gyro drifts (ε_x, ε_y).
DPHI_E0, DPHI_N0, DPHI_U0, NORTH_DRIFT = 0, 1, 2, 3
MISALIGNMENT0, TILT0 = slice(DPHI_E0, DPHI_U0 + 1), slice(DPHI_E0, DPHI_N0 + 1)
ACCEL_BIAS, GYRO_DRIFT = slice(4, 6), slice(6, 8)


@dataclass(frozen=True)
class RotationAlignmentParams:
    """Alignment filter parameters (validated, immutable).

    Attributes:
        lat_deg: latitude of the static base [deg], |lat| < 90 (ω_N = 0 at the poles).
        gravity_m_s2: local gravity [m/s²]; None = WGS-84 normal gravity at ``lat_deg``.
        accel_noise_ug_rt_hz: accelerometer white-noise density [µg/√Hz], sets R.
        block_s: averaging block [s] per RLS update.
        tilt_scale_arcsec, azimuth_scale_deg, north_drift_scale_deg_h, accel_bias_scale_ug,
            gyro_drift_scale_deg_h: normalisation scales s of the states (P0 = I in X/s):
            the a-priori size of each error. Generous values only weaken the prior.
        max_joint_age_s: largest |t_accel − t_joint| [s] bridged by extrapolating the azimuth
            with its rate; older joint data rejects the accelerometer sample.
        converged_tilt_arcsec, converged_azimuth_arcmin: σ of δφE0/δφN0 and of δφU0 below
            which the estimate is flagged converged.
        rank_rel_tol: eigenvalues of the information matrix below this fraction of the
            largest count as unobservable directions.
        sensor_error_states: estimate the level accelerometer biases and gyro drifts (paper 3's
            8 states). False is the classical static gyrocompass: their prior is zero, so the
            least squares keeps (δφE0, δφN0, δφU0, ε_N) and the level biases go into the tilt
            (∇/g) and the east drift into the azimuth (ε_E/ω_N), the gyrocompass limit.
    """

    lat_deg: float
    gravity_m_s2: float | None = None
    accel_noise_ug_rt_hz: float = 50.0
    block_s: float = 1.0
    tilt_scale_arcsec: float = 600.0
    azimuth_scale_deg: float = 2.0
    north_drift_scale_deg_h: float = 0.1
    accel_bias_scale_ug: float = 1000.0
    gyro_drift_scale_deg_h: float = 0.1
    max_joint_age_s: float = 0.1
    converged_tilt_arcsec: float = 5.0
    converged_azimuth_arcmin: float = 2.0
    rank_rel_tol: float = 1e-9
    omega_ie_rad_s: float = OMEGA_IE
    sensor_error_states: bool = True

    def __post_init__(self) -> None:
        lat = finite("lat_deg", self.lat_deg)
        if abs(lat) >= 90.0:
            raise ValueError(f"lat_deg must be in (-90, 90) (azimuth is unobservable at the poles), got {lat}")
        if self.gravity_m_s2 is not None:
            positive("gravity_m_s2", self.gravity_m_s2)
        for name in ("accel_noise_ug_rt_hz", "block_s", "tilt_scale_arcsec", "azimuth_scale_deg",
                     "north_drift_scale_deg_h", "accel_bias_scale_ug", "gyro_drift_scale_deg_h",
                     "max_joint_age_s", "converged_tilt_arcsec", "converged_azimuth_arcmin",
                     "rank_rel_tol", "omega_ie_rad_s"):
            positive(name, getattr(self, name))
        if self.rank_rel_tol >= 1.0:
            raise ValueError(f"rank_rel_tol must be < 1, got {self.rank_rel_tol}")
        of_type("sensor_error_states", self.sensor_error_states, bool)

    @classmethod
    def from_values(cls, v: dict) -> RotationAlignmentParams:
        """The parameters from a ``platform_alignment`` node's values (name -> value, as
        declared in :mod:`.platform_alignment_params`; ``gravity_m_s2`` 0 means WGS-84);
        :class:`ParameterError` names the parameter refused."""
        same = ("lat_deg", "accel_noise_ug_rt_hz", "block_s", "tilt_scale_arcsec", "azimuth_scale_deg",
                "north_drift_scale_deg_h", "accel_bias_scale_ug", "gyro_drift_scale_deg_h", "max_joint_age_s",
                "converged_tilt_arcsec", "converged_azimuth_arcmin", "sensor_error_states")  # node parameters of the field's name
        try:
            return cls(gravity_m_s2=v["gravity_m_s2"] or None, **{name: v[name] for name in same})
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc

    @property
    def lat_rad(self) -> float:
        return math.radians(self.lat_deg)

    @property
    def gravity(self) -> float:
        """Gravity [m/s²] used to turn specific force into tilt."""
        return normal_gravity(self.lat_rad) if self.gravity_m_s2 is None else float(self.gravity_m_s2)

    def state_scales(self) -> np.ndarray:
        """Normalisation scales s (8,) in SI units (rad, rad/s, m/s²)."""
        tilt = self.tilt_scale_arcsec * ARCSEC
        return np.array([
            tilt, tilt, math.radians(self.azimuth_scale_deg), self.north_drift_scale_deg_h * DEG_H,
            self.accel_bias_scale_ug * UG, self.accel_bias_scale_ug * UG,
            self.gyro_drift_scale_deg_h * DEG_H, self.gyro_drift_scale_deg_h * DEG_H,
        ])

    def prior(self) -> np.ndarray:
        """P0 (8, 8) in the normalised states: I, with the sensor-error states' rows and
        columns zero when they are not estimated (``sensor_error_states`` False)."""
        diag = np.ones(N_STATES)
        if not self.sensor_error_states:
            diag[ACCEL_BIAS] = diag[GYRO_DRIFT] = 0.0
        return np.diag(diag)


class AlignmentEstimate(NamedTuple):
    """Alignment result at time ``t`` [s].

    ``x`` (8,) in :data:`STATE_NAMES` order, SI (rad, rad/s, m/s²); ``P`` (8, 8) its
    covariance; ``sigma`` (8,) = √diag P. ``misalignment0_enu`` (3,) = the initial
    misalignment (δφE0, δφN0, δφU0) [rad] and ``misalignment0_sigma_enu`` its σ;
    ``misalignment_enu``/``misalignment_sigma_enu`` (3,) the misalignment propagated to ``t``
    (what the platform must be torqued back by). ``north_drift`` ε_N [rad/s] ± σ;
    ``gyro_drift_xy`` (2,) [rad/s] and ``accel_bias_xy`` (2,) [m/s²] in platform axes.
    ``age_s``: t − alignment start; ``n_updates``: RLS updates so far; ``converged``: the
    misalignment σ are under the configured thresholds.
    """

    t: float
    age_s: float
    n_updates: int
    x: np.ndarray
    P: np.ndarray
    sigma: np.ndarray
    misalignment0_enu: np.ndarray
    misalignment0_sigma_enu: np.ndarray
    misalignment_enu: np.ndarray
    misalignment_sigma_enu: np.ndarray
    north_drift: float
    north_drift_sigma: float
    gyro_drift_xy: np.ndarray
    gyro_drift_sigma_xy: np.ndarray
    accel_bias_xy: np.ndarray
    accel_bias_sigma_xy: np.ndarray
    converged: bool


class ObservabilityReport(NamedTuple):
    """Information content of the data so far, in the normalised states X/s.

    ``information`` (8, 8) = Σ Hᵀ R⁻¹ H (data only, no prior); ``eigenvalues`` (8,) ascending;
    ``rank``: eigenvalues above ``rank_rel_tol`` × the largest (numerical rank; the
    second-order earth-rate terms lift some directions just above round-off);
    ``informative_rank``: eigenvalues above 1, i.e. directions the data determine better
    than the P0 = I prior; ``condition`` = λmax/λmin (inf when singular);
    ``weakest_direction`` (8,) the unit eigenvector of λmin (which states the data cannot
    tell apart); ``correlation`` (8, 8) of the posterior.
    """

    information: np.ndarray
    eigenvalues: np.ndarray
    rank: int
    informative_rank: int
    condition: float
    weakest_direction: np.ndarray
    correlation: np.ndarray


_USED = Fed(True)
_NONFINITE = refused("non-finite accelerometer sample")
_JOINT_NONFINITE = refused("non-finite joint sample")


@dataclass
class _Counters(CoreCounters):
    accepted: int = 0
    rejected_no_joint: int = 0
    rejected_stale_joint: int = 0
    joint_rejected_nonfinite: int = 0


class RotationAlignmentRls:
    """8-state RLS alignment core (module docstring), message-driven and ROS-free.

    Feed :meth:`on_joint_state` with the platform azimuth joint (θ_a [rad], its rate
    [rad/s]) and :meth:`on_accel` with the platform specific force f_s (3,) [m/s²] in the
    stable-element frame (``PlatformImuSample.specific_force`` / Imu linear_acceleration).
    Each call returns what it did (:class:`~gimbal_kinematics.maths.outcome.Fed`): an
    accelerometer sample that completes an averaging block carries the new
    :class:`AlignmentEstimate` and the block's NIS. Non-finite input is rejected (``why``)
    and counted in :attr:`counters`. Stamps come checked and in order, each stream's rising: the node's
    input policy drops repeated and late ones and, on a clock jump back, calls :meth:`reset`
    (reason in ``counters.reset_reasons``).
    """

    def __init__(self, params: RotationAlignmentParams) -> None:
        of_type("params", params, RotationAlignmentParams)
        self.params = params
        lat = params.lat_rad
        self._wN = params.omega_ie_rad_s * math.cos(lat)
        self._wU = params.omega_ie_rad_s * math.sin(lat)
        self._g = params.gravity
        self._inv_g = 1.0 / self._g
        self._scales = params.state_scales()
        # white noise of one tilt sample: (N_a / g)² per unit of 1/Δt
        self._tilt_var_density = (params.accel_noise_ug_rt_hz * UG / self._g) ** 2
        self.counters = _Counters()
        self._joint: tuple[float, float, float | None] | None = None  # (t, θ_a, rate)
        self._joint_prev: tuple[float, float] | None = None
        self._restart()

    # -- state handling ------------------------------------------------------------------
    def _restart(self) -> None:
        self._xi, self._P = check_state(np.zeros(N_STATES), self.params.prior(), "RotationAlignmentRls")
        self._info = np.zeros((N_STATES, N_STATES))
        self._t0: float | None = None
        self._t_last: float | None = None
        self._psi_last = 0.0
        self._ic = self._is = 0.0
        self._n_updates = 0
        self.last_nis = math.nan
        self._t_update: float | None = None
        self._clear_block()

    def _clear_block(self) -> None:
        # sums over the block of: t, cos ψ, sin ψ, I_s, I_c, Z_E, Z_N, 1/Δt, t²; sample count
        self._b = [0.0] * 9
        self._bn = 0
        self._b_start = self._t_last

    def reset(self, reason: str) -> None:
        """Restart the alignment from X0 = 0, P0 = :meth:`RotationAlignmentParams.prior`; ``reason`` is recorded."""
        self.counters.count_reset(reason)
        self._joint = None
        self._joint_prev = None
        self._restart()

    # -- inputs --------------------------------------------------------------------------
    def on_joint_state(self, t: float, theta_a: float, theta_a_rate: float | None = None) -> Fed:
        """Platform azimuth joint at time ``t`` [s]: θ_a [rad] about NED down (= −φz of the
        paper) and optionally its rate [rad/s] (else differenced from the previous sample);
        returns what it did (:class:`~gimbal_kinematics.maths.outcome.Fed`)."""
        try:
            t, theta_a = float(t), float(theta_a)
            rate = None if theta_a_rate is None else float(theta_a_rate)
        except (TypeError, ValueError):
            self.counters.joint_rejected_nonfinite += 1
            return _JOINT_NONFINITE
        if not (math.isfinite(t) and math.isfinite(theta_a) and (rate is None or math.isfinite(rate))):
            self.counters.joint_rejected_nonfinite += 1
            return _JOINT_NONFINITE
        if rate is None and self._joint is not None:
            t_p, a_p = self._joint[0], self._joint[1]
            rate = math.remainder(theta_a - a_p, math.tau) / (t - t_p)
        self._joint = (t, theta_a, rate)
        return _USED

    def _azimuth_at(self, t: float) -> float | str:
        """ψ at ``t`` [rad] from the newest joint sample, or why there is none (counted)."""
        j = self._joint
        if j is None:
            self.counters.rejected_no_joint += 1
            return "no joint angle yet"
        age = t - j[0]
        if abs(age) > self.params.max_joint_age_s:
            self.counters.rejected_stale_joint += 1
            return "joint angle older than max_joint_age_s"
        return j[1] + (j[2] * age if j[2] is not None else 0.0)

    def on_accel(self, t: float, f_s: Sequence[float]) -> Fed:
        """Platform specific force ``f_s`` (3,) [m/s²] in the stable-element frame at ``t``
        [s]; returns what it did (:class:`~gimbal_kinematics.maths.outcome.Fed`): the
        estimate (``output``) and the block's NIS when this sample completes an averaging
        block."""
        try:
            t = float(t)
            fx, fy = float(f_s[0]), float(f_s[1])
        except (TypeError, ValueError, IndexError):
            self.counters.rejected_nonfinite += 1
            return _NONFINITE
        if not (math.isfinite(t) and math.isfinite(fx) and math.isfinite(fy)):
            self.counters.rejected_nonfinite += 1
            return _NONFINITE
        psi = self._azimuth_at(t)
        if isinstance(psi, str):
            return refused(psi)
        self.counters.accepted += 1
        c, s = math.cos(psi), math.sin(psi)
        if self._t0 is None:
            # first sample: fixes the alignment epoch and the start of the ψ integrals
            self._t0, self._t_last, self._psi_last = t, t, psi
            self._b_start = t
            return _USED
        dt = t - self._t_last
        cp, sp = math.cos(self._psi_last), math.sin(self._psi_last)
        self._ic += 0.5 * (cp + c) * dt
        self._is += 0.5 * (sp + s) * dt
        self._t_last, self._psi_last = t, psi
        inv_g = self._inv_g
        b = self._b
        tau = t - self._t0
        b[0] += tau
        b[8] += tau * tau
        b[1] += c
        b[2] += s
        b[3] += self._is
        b[4] += self._ic
        b[5] += (c * fx - s * fy) * inv_g  # Z_E = f_N / g
        b[6] -= (s * fx + c * fy) * inv_g  # Z_N = −f_E / g
        b[7] += 1.0 / dt
        self._bn += 1
        if t - self._b_start < self.params.block_s * (1.0 - 1e-9):  # stamps k·dt carry round-off
            return _USED
        self._update_block()
        return Fed(True, output=self.estimate(), nis=self.last_nis)

    # -- RLS update ----------------------------------------------------------------------
    def _update_block(self) -> None:
        n = self._bn
        b = [v / n for v in self._b]
        var = self._tilt_var_density * b[7] / n
        H = self._rows(b[0], b[8], b[1], b[2], b[3], b[4], with_bias=True)
        w = 1.0 / math.sqrt(var)
        Hw = (H * self._scales) * w  # normalised states, whitened rows: R = I
        zw = np.array([b[5], b[6]]) * w
        upd = joseph_update(self._xi, self._P, zw, Hw, np.eye(2))
        self._xi, self._P = upd.x, upd.P
        #: NIS of the last block update (2 dof; whitened rows, so S = Hw P Hwᵀ + I) [-]
        self.last_nis = upd.d2
        self._info += Hw.T @ Hw
        self._n_updates += 1
        self._t_update = self._t_last
        self._clear_block()

    def _rows(self, t: float, t2: float, c: float, s: float, i_s: float, i_c: float,
              with_bias: bool) -> np.ndarray:
        """The two rows of H (module docstring) for (block means of) t, t², cos ψ, sin ψ,
        I_s, I_c; without the accelerometer columns they map X to the misalignment."""
        wN, wU = self._wN, self._wU
        w2 = wN * wN + wU * wU
        h2 = 0.5 * t2
        gc, gs = (c * self._inv_g, s * self._inv_g) if with_bias else (0.0, 0.0)
        return np.array([
            [1.0 - w2 * h2, wU * t, -wN * t, wU * h2, gc, -gs, i_s, i_c],
            [-wU * t, 1.0 - wU * wU * h2, wN * wU * h2, t, -gs, -gc, i_c, -i_s],
        ])

    # -- outputs -------------------------------------------------------------------------
    @property
    def started(self) -> bool:
        return self._t0 is not None

    @property
    def n_updates(self) -> int:
        return self._n_updates

    def estimate(self) -> AlignmentEstimate:
        """Current estimate (module docstring for the state meaning)."""
        sc = self._scales
        x = self._xi * sc
        P = symmetrize(self._P * np.outer(sc, sc))
        sigma = np.sqrt(np.clip(np.diag(P), 0.0, None))
        t = self._t_update if self._t_update is not None else (self._t_last or 0.0)
        tau = t - (self._t0 if self._t0 is not None else t)
        # φ(t) = G X: the rows of H without the accelerometer terms, plus
        # δφU(t) = δφU0 + ω_N δφE0 t (ε_U is not a state)
        up = np.zeros(N_STATES)
        up[DPHI_E0], up[DPHI_U0] = self._wN * tau, 1.0
        G = np.vstack((self._rows(tau, tau * tau, 1.0, 0.0, self._is, self._ic, with_bias=False), up))
        Pg = G @ P @ G.T
        p = self.params
        converged = bool(
            self._n_updates > 0
            and max(sigma[DPHI_E0], sigma[DPHI_N0]) < p.converged_tilt_arcsec * ARCSEC
            and sigma[DPHI_U0] < p.converged_azimuth_arcmin * ARCMIN
        )
        return AlignmentEstimate(
            t=t, age_s=tau, n_updates=self._n_updates, x=x, P=P, sigma=sigma,
            misalignment0_enu=x[MISALIGNMENT0].copy(), misalignment0_sigma_enu=sigma[MISALIGNMENT0].copy(),
            misalignment_enu=G @ x, misalignment_sigma_enu=np.sqrt(np.clip(np.diag(Pg), 0.0, None)),
            north_drift=float(x[NORTH_DRIFT]), north_drift_sigma=float(sigma[NORTH_DRIFT]),
            gyro_drift_xy=x[GYRO_DRIFT].copy(), gyro_drift_sigma_xy=sigma[GYRO_DRIFT].copy(),
            accel_bias_xy=x[ACCEL_BIAS].copy(), accel_bias_sigma_xy=sigma[ACCEL_BIAS].copy(),
            converged=converged,
        )

    def observability(self) -> ObservabilityReport:
        """Rank/conditioning of the data information and posterior correlations."""
        info = symmetrize(self._info)
        eig, vec = np.linalg.eigh(info)
        lam_max = float(eig[-1])
        rank = int(np.sum(eig > self.params.rank_rel_tol * lam_max)) if lam_max > 0.0 else 0
        cond = lam_max / float(eig[0]) if eig[0] > 0.0 else math.inf
        d = np.sqrt(np.diag(self._P))
        d = np.where(d > 0.0, d, math.inf)  # a state held at zero correlates with nothing
        return ObservabilityReport(
            information=info, eigenvalues=eig, rank=rank, informative_rank=int(np.sum(eig > 1.0)), condition=cond,
            weakest_direction=vec[:, 0], correlation=self._P / np.outer(d, d),
        )
