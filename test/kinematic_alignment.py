"""Paper 3 alignment on a kinematic platform truth (Table 2 style), the rotation-alignment
tests' independent reference: the truth is built from rotation matrices, not from the
measurement model H of :mod:`gimbal_estimators.rotation_alignment`: the platform attitude in
inertial space is integrated from its commanded rate (``four_gimbal.command_rate_s``: level,
earth-rate compensated, turning by ψ(t)) plus the gyro drift, the NED frame is turned with the
earth (``free_gyro.dcm_ni``), and the accelerometers sense C_sn,true (0, 0, −g) through the
simulator's :class:`~gimbal_sim.world.sensors.AccelerometerModel`. The harness steps the truth,
the accelerometers and the core itself (a test's own loop: the product's Table 2 campaign
runs scenario ``rotational_ins_alignment`` on the engine).

Conventions (state order, ENU misalignment, units) are those of
:mod:`gimbal_estimators.rotation_alignment`.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_estimators.rotation_alignment import (
    ACCEL_BIAS, DPHI_E0, DPHI_N0, DPHI_U0, GYRO_DRIFT, N_STATES, NORTH_DRIFT, TILT0, RotationAlignmentParams,
    RotationAlignmentRls,
)
from gimbal_kinematics.maths.earth import OMEGA_IE, normal_gravity
from gimbal_kinematics.maths.four_gimbal import BidirectionalRotation, platform_misalignment_enu
from gimbal_kinematics.maths.free_gyro import dcm_ni
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, rot3
from gimbal_kinematics.maths.units import ARCMIN, ARCSEC, DEG_H, UG
from gimbal_sim.experiments.platform_servo import PAPER3_MISALIGNMENT_ARCSEC
from gimbal_sim.reports.alignment import column_stats
from gimbal_sim.world.sensors import PAPER3_ACCELEROMETER, AccelerometerModel


class KinematicPlatformTruth:
    """Platform held level by an ideal servo that follows its drifting gyro reference.

    Args:
        lat: latitude [rad].
        misalignment0_enu: initial misalignment (δφE0, δφN0, δφU0) [rad] (module convention).
        gyro_drift_s: platform gyro drift (3,) [rad/s] in platform axes (rotates with ψ).
        nav_drift_n: drift fixed in NED (3,) [rad/s] (torquer/command errors; its north
            component is paper 3's ε_N state).
        rotation: ψ(t) schedule (``BidirectionalRotation``) or None for a fixed azimuth.
        psi0: azimuth offset [rad] added to the schedule (the fixed azimuth when None).
        gravity: |g| [m/s²].
    """

    def __init__(self, lat: float, misalignment0_enu: Sequence[float], gyro_drift_s: Sequence[float],
                 nav_drift_n: Sequence[float] = (0.0, 0.0, 0.0), rotation=None, psi0: float = 0.0,
                 gravity: float | None = None, omega_ie: float = OMEGA_IE) -> None:
        self._dcm_ni = dcm_ni
        self._exp = dcm_from_rotation_vector
        self.lat = float(lat)
        self.omega_ie = float(omega_ie)
        self.g = normal_gravity(self.lat) if gravity is None else float(gravity)
        self.rotation = rotation
        self.psi0 = float(psi0)
        self.gyro_drift_s = np.asarray(gyro_drift_s, dtype=float).reshape(3)
        self.nav_drift_n = np.asarray(nav_drift_n, dtype=float).reshape(3)
        e, n, u = (float(v) for v in misalignment0_enu)
        phi_ned = np.array([n, e, -u])
        self.t = 0.0
        C_ns = dcm_from_rotation_vector(phi_ned) @ rot3(self.psi()).T
        self.C_is = dcm_ni(self.lat, 0.0, 0.0).T @ C_ns
        self._w_ie_n = (self.omega_ie * math.cos(self.lat), 0.0, -self.omega_ie * math.sin(self.lat))

    def psi_state(self, t: float) -> tuple[float, float]:
        """Believed (ideal) platform azimuth ψ [rad] and its rate [rad/s] at ``t``."""
        if self.rotation is None:
            return self.psi0, 0.0
        ang, rate, _ = self.rotation.state(t)
        return self.psi0 + ang, rate

    def psi(self, t: float | None = None) -> float:
        return self.psi_state(self.t if t is None else t)[0]

    def C_ns(self) -> np.ndarray:
        """True platform attitude ``C_ns`` at the current time; (3, 3)."""
        return self._dcm_ni(self.lat, 0.0, self.t) @ self.C_is

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s]: C_is ← C_is exp([ω_is^s dt ×]) with the commanded rate
        rot3(ψ) ω_ie^n + ψ̇ e3 (exact ψ increment, mid-step azimuth) plus the drifts."""
        t0, t1 = self.t, self.t + dt
        psi_a, psi_b, psi_m = self.psi(t0), self.psi(t1), self.psi(0.5 * (t0 + t1))
        c, s = math.cos(psi_m), math.sin(psi_m)
        wn, we, wd = self._w_ie_n
        rotvec = np.array([(c * wn + s * we) * dt, (-s * wn + c * we) * dt, wd * dt + (psi_b - psi_a)])
        rotvec += self.gyro_drift_s * dt
        if np.any(self.nav_drift_n):
            rotvec += self.C_ns().T @ self.nav_drift_n * dt
        self.C_is = self.C_is @ self._exp(rotvec)
        self.t = t1

    def specific_force_s(self) -> np.ndarray:
        """True specific force in platform axes [m/s²] on the static base; (3,)."""
        return self.C_ns().T @ np.array([0.0, 0.0, -self.g])

    def misalignment_enu(self) -> np.ndarray:
        """True misalignment (δφE, δφN, δφU) [rad] relative to the ideal level frame at ψ."""
        return platform_misalignment_enu(self.C_ns(), self.psi())


class AlignmentMetrics(NamedTuple):
    """One alignment run against its truth (units in the field names; errors = est − truth).

    ``truth``/``estimate``/``sigma`` (8,) in :data:`STATE_NAMES` order, SI. ``rank``,
    ``informative_rank`` and ``condition`` of the data information (normalised states,
    :class:`ObservabilityReport`); ``corr_tilt_bias`` the
    posterior correlations of (δφE0, ∇ along north) and (δφN0, ∇ along east) at the start
    azimuth — near ±1 when bias and tilt are confounded.
    """

    seed: int
    rotate: bool
    duration_s: float
    truth: np.ndarray
    estimate: np.ndarray
    sigma: np.ndarray
    tilt_error_arcsec: np.ndarray
    tilt_sigma_arcsec: np.ndarray
    azimuth_error_arcmin: float
    azimuth_sigma_arcmin: float
    north_drift_error_deg_h: float
    north_drift_sigma_deg_h: float
    gyro_drift_error_deg_h: np.ndarray
    accel_bias_error_ug: np.ndarray
    converged: bool
    rank: int
    informative_rank: int
    condition: float
    corr_tilt_bias: np.ndarray
    n_updates: int


def alignment_metrics(core: RotationAlignmentRls, truth_x: np.ndarray, *, seed: int, rotate: bool,
                      duration_s: float, psi0: float) -> AlignmentMetrics:
    """The metrics of a finished alignment run against its truth ``truth_x`` (8,) (state
    order, SI); ``psi0`` [rad] is the platform azimuth at the start (for the tilt/bias
    correlations)."""
    est = core.estimate()
    err = est.x - truth_x
    obs = core.observability()
    # ∇ along north / east at the start azimuth ψ0: ∇N = c ∇x − s ∇y, ∇E = s ∇x + c ∇y
    c0, s0 = math.cos(psi0), math.sin(psi0)
    a_n = np.zeros(N_STATES); a_n[ACCEL_BIAS] = c0, -s0
    a_e = np.zeros(N_STATES); a_e[ACCEL_BIAS] = s0, c0
    P = core._P

    def _corr(i: int, a: np.ndarray) -> float:
        var = P[i, i] * (a @ P @ a)
        return float((P[i] @ a) / math.sqrt(var)) if var > 0.0 else 0.0  # a state held at zero: none

    return AlignmentMetrics(
        seed=int(seed), rotate=bool(rotate), duration_s=float(duration_s), truth=truth_x, estimate=est.x,
        sigma=est.sigma, tilt_error_arcsec=err[TILT0] / ARCSEC, tilt_sigma_arcsec=est.sigma[TILT0] / ARCSEC,
        azimuth_error_arcmin=float(err[DPHI_U0] / ARCMIN), azimuth_sigma_arcmin=float(est.sigma[DPHI_U0] / ARCMIN),
        north_drift_error_deg_h=float(err[NORTH_DRIFT] / DEG_H),
        north_drift_sigma_deg_h=float(est.sigma[NORTH_DRIFT] / DEG_H),
        gyro_drift_error_deg_h=err[GYRO_DRIFT] / DEG_H, accel_bias_error_ug=err[ACCEL_BIAS] / UG,
        converged=est.converged, rank=obs.rank, informative_rank=obs.informative_rank, condition=obs.condition,
        corr_tilt_bias=np.array([_corr(DPHI_E0, a_n), _corr(DPHI_N0, a_e)]), n_updates=est.n_updates,
    )


def summarize_alignment(runs: Sequence[AlignmentMetrics]) -> dict[str, dict[str, float]]:
    """Mean, std (ddof=1, as Table 2), RMS and max |·| over runs of the headline errors."""
    cols = {
        "east_tilt_error_arcsec": [r.tilt_error_arcsec[0] for r in runs],
        "north_tilt_error_arcsec": [r.tilt_error_arcsec[1] for r in runs],
        "azimuth_error_arcmin": [r.azimuth_error_arcmin for r in runs],
        "north_drift_error_deg_h": [r.north_drift_error_deg_h for r in runs],
        "gyro_drift_x_error_deg_h": [r.gyro_drift_error_deg_h[0] for r in runs],
        "gyro_drift_y_error_deg_h": [r.gyro_drift_error_deg_h[1] for r in runs],
        "accel_bias_x_error_ug": [r.accel_bias_error_ug[0] for r in runs],
        "accel_bias_y_error_ug": [r.accel_bias_error_ug[1] for r in runs],
    }
    return column_stats(cols)


def run_alignment_experiment(
    seed: int,
    rotate: bool = True,
    duration_s: float = 600.0,
    *,
    lat_deg: float = 40.0,
    imu_rate_hz: float = 100.0,
    misalignment0_arcsec: tuple = PAPER3_MISALIGNMENT_ARCSEC,
    gyro_drift_sigma_deg_h: float = 0.03,
    north_drift_sigma_deg_h: float = 0.01,
    east_nav_drift_deg_h: float = 0.0,
    fixed_psi_deg: float = 30.0,
    accel_params=None,
    params: RotationAlignmentParams | None = None,
) -> AlignmentMetrics:
    """Kinematic-truth alignment run (paper 3 §2.2 / Table 2), returns its metrics.

    ``rotate``: bidirectional 1.2°/s through 360° and back (600 s = one cycle, paper 3's
    "rotates bi-directionally ... in one circle"), else the platform is held at
    ``fixed_psi_deg``. Platform gyro drift per axis ~ N(0, ``gyro_drift_sigma_deg_h``²); the
    n-fixed north drift ~ N(0, ``north_drift_sigma_deg_h``²); an n-fixed east drift
    ``east_nav_drift_deg_h`` (unobservable, biases azimuth by −εE/ω_N). Accelerometers:
    ``accel_params`` (default ``PAPER3_ACCELEROMETER``: 100 µg bias σ, 50 µg/√Hz) sampled at
    ``imu_rate_hz``; the filter's noise density follows it unless ``params`` is given.
    """
    accel_params = PAPER3_ACCELEROMETER if accel_params is None else accel_params
    if params is None:
        params = RotationAlignmentParams(lat_deg=lat_deg, accel_noise_ug_rt_hz=max(accel_params.noise_ug_rt_hz, 1e-3))
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 3])
    gyro_drift = rng.normal(0.0, gyro_drift_sigma_deg_h, 3) * DEG_H
    north_drift = float(rng.normal(0.0, north_drift_sigma_deg_h)) * DEG_H
    nav_drift = np.array([north_drift, east_nav_drift_deg_h * DEG_H, 0.0])
    rotation = BidirectionalRotation() if rotate else None
    lat = math.radians(lat_deg)
    truth = KinematicPlatformTruth(
        lat, np.asarray(misalignment0_arcsec, dtype=float) * ARCSEC, gyro_drift, nav_drift,
        rotation=rotation, psi0=0.0 if rotate else math.radians(fixed_psi_deg), gravity=params.gravity,
    )
    dt = 1.0 / imu_rate_hz
    accel = AccelerometerModel(accel_params, 3, np.random.default_rng([int(seed) & 0xFFFFFFFF, 4]), dt)
    core = RotationAlignmentRls(params)
    phi0 = truth.misalignment_enu()
    n_steps = int(round(duration_s * imu_rate_hz))
    for k in range(n_steps + 1):
        if k:
            truth.step(dt)
        psi, psi_dot = truth.psi_state(truth.t)
        core.on_joint_state(truth.t, psi, psi_dot)
        core.on_accel(truth.t, accel.step(truth.specific_force_s()))
    bias = accel.fixed_bias
    truth_x = np.array([phi0[0], phi0[1], phi0[2], north_drift, bias[0], bias[1], gyro_drift[0], gyro_drift[1]])
    return alignment_metrics(core, truth_x, seed=seed, rotate=rotate, duration_s=duration_s, psi0=truth.psi(0.0))
