"""Sensor suite core: turns the vehicle's truth into measurements (no rclpy).

Each enabled sensor runs at its own rate, an integer divisor of the simulation rate, and
takes its own random stream: ``numpy.random.default_rng([seed, crc32(sensor name)])``, so
enabling or re-rating one sensor never changes another's noise. Sensors:

* ``ins``: host INS attitude and body rates with paper 1's errors (:mod:`.sensors.ins`);
* ``gimbal_gyro``: two-axis rate gyro on the inner gimbal (q_m, r_m only);
* ``encoders``: turret, gimbal azimuth and elevation encoders (angle and pulse-rate);
* ``lgu``: the two ring-laser-gyro units of paper 5 with the ship flexure between them;
  LGU increments are accumulated at the simulation rate and published at ``lgu_rate_hz``;
* ``platform_imu``: accelerometer and gyro triads on the paper 3 stable element;
* ``free_gyro``: paper 4's two free gyros (inertially fixed spin axes read out in the ship's
  body), its body gyro triad and vertical reference, for a ship at ``free_gyro_site_deg``
  (the vehicle stays at its profile's site, which it does not publish, so the two must
  agree); the triad gets the exact rotation over each sample interval divided by it.
* ``resolvers``: the paper 3 gimbal resolvers (θ_a, θ_q, θ_p, θ_r; the azimuth multi-turn),
  quantised like its 19-bit resolver-to-digital converters, with their tracking velocity.
* ``dtg``: paper 3's two dynamically tuned gyros on the stable element (:mod:`.sensors.dtg`),
  integrated every step through the platform's inertial rotation under the torquer
  currents the servo commanded at the step before (:meth:`SensorSuite.update`'s
  ``torquer_current_a``); their four pickoff angles every step (the DTG has no rate of its
  own: the rotor integrates the platform's motion between any two reads).
"""
from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.frames import DTG_PICKOFF_JOINTS
from gimbal_kinematics.maths.free_gyro import spin_axes_for_site_deg
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, rotation_vector_from_dcm
from gimbal_kinematics.maths.units import URAD

from .sensors import (
    PAPER1_ENCODER, PAPER1_GIMBAL_GYRO, PAPER3_ACCELEROMETER, PAPER3_GYRO, LGU1_GYRO, LGU2_GYRO,
    AccelerometerModel, AccelerometerParams, EncoderModel, EncoderParams, FlexureParams, GyroModel,
    GyroParams, HullParams, InsModel, InsParams, LguPair, ShipFlexureTruth,
)
from .sensors.dtg import DtgOnPlatform, DtgPair, DtgPairParams
from .sensors.free_gyro_sensor import FreeGyroSample, FreeGyroSensor, FreeGyroSensorParams
from .sensors.inertial_core import off_diagonal
from .vehicle import VehicleTruth

#: Sensor name -> the config field holding its output rate [Hz].
SENSOR_RATES = {"ins": "ins_rate_hz", "gimbal_gyro": "gimbal_gyro_rate_hz", "encoders": "encoder_rate_hz",
                "lgu": "lgu_rate_hz", "platform_imu": "platform_imu_rate_hz", "free_gyro": "free_gyro_rate_hz",
                "resolvers": "resolver_rate_hz", "dtg": "sim_rate_hz"}
SENSORS = tuple(SENSOR_RATES)

#: Default free-gyro ship site (off Busan, paper 4's authors) [deg], and spin axes set there at
#: t = 0 to nadir angles (60°, 50°) and azimuths (−40°, 50°): Δα = 90°, FDOP = √2.
FREE_GYRO_SITE_DEG = (35.0, 129.0)


def _default_free_gyro() -> FreeGyroSensorParams:
    return FreeGyroSensorParams(*spin_axes_for_site_deg(*FREE_GYRO_SITE_DEG, (60.0, 50.0), (-40.0, 50.0)))


def _scale_errors(v: dict, prefix: str, n: int) -> dict:
    """The scale-factor, asymmetry and misalignment fields of a ``GyroParams`` or
    ``AccelerometerParams`` from a ``sensor_models`` node's ``<prefix>_*`` values (n axes);
    ``ValueError`` naming the parameter at fault."""
    out = {}
    for name, key in (("scale_factor_ppm", "scale_factor_ppm"), ("scale_asymmetry_ppm", "scale_asymmetry_ppm")):
        values = tuple(float(x) for x in v[f"{prefix}_{name}"])
        if len(values) not in (1, n) or not all(math.isfinite(x) for x in values):
            raise ValueError(f"parameter '{prefix}_{name}' needs one finite value (every axis) or {n} (one per "
                             f"axis), got {list(values)}")
        out[key] = values
    out["scale_factor_sigma_ppm"] = v[f"{prefix}_scale_factor_sigma_ppm"]
    out["scale_asymmetry_sigma_ppm"] = v[f"{prefix}_scale_asymmetry_sigma_ppm"]
    out["misalignment_rad"] = off_diagonal(f"parameter '{prefix}_misalignment_urad'", v[f"{prefix}_misalignment_urad"],
                                           n, URAD)
    out["misalignment_sigma_urad"] = v[f"{prefix}_misalignment_sigma_urad"]
    return out


def _free_gyro_params_from(v: dict) -> FreeGyroSensorParams:
    """The free-gyro sensor parameters from a ``sensor_models`` node's values; ``ValueError``
    naming the parameter at fault."""
    u_a, u_b = spin_axes_for_site_deg(v["free_gyro_site_lat_deg"], v["free_gyro_site_lon_deg"],
                                      v["free_gyro_nadir_deg"], v["free_gyro_azimuth_deg"],
                                      names=("free_gyro_nadir_deg", "free_gyro_azimuth_deg"))
    level_bias = v["free_gyro_level_bias_arcsec"]
    if len(level_bias) != 2 or not all(math.isfinite(x) for x in level_bias):
        raise ValueError(f"parameter 'free_gyro_level_bias_arcsec' needs two finite values (roll, pitch), "
                         f"got {list(level_bias)}")
    try:
        triad_errors = _scale_errors(v, "free_gyro_triad", 3)
    except ValueError as exc:
        raise ValueError(str(exc)) from exc
    try:
        triad = GyroParams(bias_deg_h=tuple(v["free_gyro_triad_bias_deg_h"]),
                           arw_deg_rt_h=v["free_gyro_triad_arw_deg_rt_h"],
                           bias_sigma_deg_h=v["free_gyro_triad_bias_sigma_deg_h"], **triad_errors)
    except ValueError as exc:
        raise ValueError(f"parameter 'free_gyro_triad_bias_deg_h': {exc}") from exc
    try:
        return FreeGyroSensorParams(
            u_a, u_b, pickoff_noise_arcsec=v["free_gyro_pickoff_noise_arcsec"],
            spin_drift_sigma_deg_h=v["free_gyro_spin_drift_sigma_deg_h"],
            level_noise_arcsec=v["free_gyro_level_noise_arcsec"], level_bias_arcsec=tuple(level_bias), triad=triad,
            speed_m_s=v["free_gyro_speed_m_s"], course_deg=v["free_gyro_course_deg"],
            caging_error_arcsec=v["free_gyro_caging_error_arcsec"],
            gm_drift_sigma_deg_h=v["free_gyro_gm_drift_sigma_deg_h"], gm_drift_tau_s=v["free_gyro_gm_drift_tau_s"],
            lock_guard_deg=v["free_gyro_lock_guard_deg"],
            lock_suppression_rate_deg_h=v["free_gyro_lock_suppression_rate_deg_h"],
            spin_rate_arw_deg_rt_h=v["free_gyro_spin_rate_arw_deg_rt_h"])
    except ValueError as exc:  # what is left to refuse is the pair of spin axes (parallel)
        raise ValueError(f"parameters 'free_gyro_nadir_deg', 'free_gyro_azimuth_deg': {exc}") from exc


def _dtg_params_from(v: dict) -> DtgPairParams:
    """The DTG pair's parameters from a ``sensor_models`` node's ``dtg_*`` values;
    ``ValueError`` naming the parameter at fault."""
    for name in ("dtg_scale_error_ppm", "dtg_drift_deg_h"):
        if len(v[name]) != 4 or not all(math.isfinite(x) for x in v[name]):
            raise ValueError(f"parameter '{name}' needs four finite values (lower x, y, upper x, y), "
                             f"got {list(v[name])}")
    return DtgPairParams(scale_deg_h_ma=v["dtg_torquer_scale_deg_h_ma"],
                         scale_error_ppm=tuple(float(x) for x in v["dtg_scale_error_ppm"]),
                         drift_deg_h=tuple(float(x) for x in v["dtg_drift_deg_h"]),
                         drift_sigma_deg_h=v["dtg_drift_sigma_deg_h"], arw_deg_rt_h=v["dtg_arw_deg_rt_h"],
                         pickoff_noise_arcsec=v["dtg_pickoff_noise_arcsec"], max_current_ma=v["dtg_max_current_ma"])


#: Paper 3 §3: 19-bit tracking resolver-to-digital converters (2π/2¹⁹ ≈ 2.5″ per count);
#: the tracking velocity is taken as counts over a 10 ms gate.
PAPER3_RESOLVER = EncoderParams(lines_per_rev=2 ** 19, quadrature=1, velocity_gate_s=0.01)


@dataclass(frozen=True)
class SensorSuiteConfig:
    """Which sensors run, at what rates [Hz], with which error parameters."""

    sensors: tuple[str, ...] = ("ins", "gimbal_gyro", "encoders")
    sim_rate_hz: float = 1000.0
    seed: int = 0
    ins_rate_hz: float = 100.0
    gimbal_gyro_rate_hz: float = 1000.0
    encoder_rate_hz: float = 1000.0
    lgu_rate_hz: float = 100.0
    platform_imu_rate_hz: float = 100.0
    free_gyro_rate_hz: float = 10.0
    resolver_rate_hz: float = 1000.0
    ins: InsParams = field(default_factory=InsParams)
    gimbal_gyro: GyroParams = PAPER1_GIMBAL_GYRO
    encoder: EncoderParams = PAPER1_ENCODER
    flexure: FlexureParams = field(default_factory=FlexureParams)
    lgu1: GyroParams = LGU1_GYRO
    lgu2: GyroParams = LGU2_GYRO
    platform_gyro: GyroParams = PAPER3_GYRO
    platform_accel: AccelerometerParams = PAPER3_ACCELEROMETER
    free_gyro_site_deg: tuple[float, float] = FREE_GYRO_SITE_DEG
    free_gyro: FreeGyroSensorParams = field(default_factory=_default_free_gyro)
    resolver: EncoderParams = PAPER3_RESOLVER
    dtg: DtgPairParams = field(default_factory=DtgPairParams)
    #: the base's latitude [deg]: the n frame the DTGs' rotors see turning at the earth rate there
    dtg_lat_deg: float = 45.0

    def __post_init__(self) -> None:
        unknown = [s for s in self.sensors if s not in SENSORS]
        if unknown:
            raise ValueError(f"sensors: unknown {unknown}; known: {list(SENSORS)}")
        if not (math.isfinite(self.sim_rate_hz) and self.sim_rate_hz > 0.0):
            raise ValueError(f"sim_rate_hz must be > 0, got {self.sim_rate_hz}")
        for sensor in self.sensors:
            self.decimation(SENSOR_RATES[sensor])
        lat, lon = (float(v) for v in self.free_gyro_site_deg)
        if not (abs(lat) <= 90.0 and abs(lon) <= 360.0):
            raise ValueError(f"free_gyro_site_deg must be (lat in [-90, 90], lon in [-360, 360]) deg, "
                             f"got {self.free_gyro_site_deg}")

    @classmethod
    def from_values(cls, v: dict) -> SensorSuiteConfig:
        """The config from a ``sensor_models`` node's values (name -> value, as declared in
        :mod:`..nodes.sensor_models_params`); :class:`ParameterError` names the parameter refused."""
        try:
            return cls(
                sensors=tuple(v["sensors"]), sim_rate_hz=v["sim_rate_hz"], seed=v["seed"],
                ins_rate_hz=v["ins_rate_hz"], gimbal_gyro_rate_hz=v["gimbal_gyro_rate_hz"],
                encoder_rate_hz=v["encoder_rate_hz"], lgu_rate_hz=v["lgu_rate_hz"],
                platform_imu_rate_hz=v["platform_imu_rate_hz"],
                gimbal_gyro=GyroParams(bias_deg_h=tuple(v["gimbal_gyro_bias_deg_h"]),
                                       bias_sigma_deg_h=v["gimbal_gyro_bias_sigma_deg_h"],
                                       arw_deg_rt_h=v["gimbal_gyro_arw_deg_rt_h"],
                                       bias_instability_deg_h=v["gimbal_gyro_bi_deg_h"],
                                       bias_instability_tau_s=v["gimbal_gyro_bi_tau_s"],
                                       rrw_deg_h_rt_h=v["gimbal_gyro_rrw_deg_h_rt_h"],
                                       quantisation_rad=math.radians(v["gimbal_gyro_quantum_deg"]),
                                       saturation_deg_s=v["gimbal_gyro_range_deg_s"] or math.inf,
                                       **_scale_errors(v, "gimbal_gyro", 2)),
                ins=InsParams(roll_pitch_rms_deg=v["ins_roll_pitch_rms_deg"], heading_rms_deg=v["ins_heading_rms_deg"],
                              attitude_tau_s=v["ins_attitude_tau_s"], attitude_model=v["ins_attitude_model"],
                              schuler_period_s=v["ins_schuler_period_s"],
                              schuler_damping=v["ins_schuler_damping"],
                              gyro=GyroParams(bias_sigma_deg_h=v["ins_gyro_bias_sigma_deg_h"],
                                              bias_instability_deg_h=v["ins_gyro_bi_deg_h"],
                                              bias_instability_tau_s=v["ins_gyro_bi_tau_s"],
                                              arw_deg_rt_h=v["ins_gyro_arw_deg_rt_h"],
                                              rrw_deg_h_rt_h=v["ins_gyro_rrw_deg_h_rt_h"],
                                              quantisation_rad=math.radians(v["ins_gyro_quantum_deg"]),
                                              **_scale_errors(v, "ins_gyro", 3))),
                encoder=EncoderParams(noise_deg=v["encoder_noise_deg"], lines_per_rev=v["encoder_lines_per_rev"],
                                      quadrature=v["encoder_quadrature"], velocity_gate_s=v["encoder_velocity_gate_s"]),
                lgu1=GyroParams(bias_deg_h=v["lgu1_bias_deg_h"], arw_deg_rt_h=v["lgu_arw_deg_rt_h"],
                                **_scale_errors(v, "lgu", 3)),
                lgu2=GyroParams(bias_deg_h=v["lgu2_bias_deg_h"], arw_deg_rt_h=v["lgu_arw_deg_rt_h"],
                                **_scale_errors(v, "lgu", 3)),
                flexure=FlexureParams(initial_deg=v["flexure_initial_deg"],
                                      linear_rate_deg_h=v["flexure_linear_rate_deg_h"],
                                      slow_amplitude_arcsec=v["flexure_slow_amplitude_arcsec"],
                                      slow_period_s=v["flexure_slow_period_s"],
                                      helm_amplitude_deg=v["flexure_helm_amplitude_deg"],
                                      helm_period_s=v["flexure_helm_period_s"],
                                      dynamic_rms_arcsec=tuple(v["flexure_dynamic_rms_arcsec"]),
                                      dynamic_beta_per_s=tuple(v["flexure_dynamic_beta_per_s"]),
                                      dynamic_freq_rad_s=tuple(v["flexure_dynamic_freq_rad_s"]),
                                      dynamic_model=v["flexure_dynamic_model"],
                                      hull=HullParams(sea_state=v["flexure_sea_state"],
                                                      wave_height_m=v["flexure_wave_height_m"],
                                                      wave_period_s=v["flexure_wave_period_s"],
                                                      speed_m_s=v["flexure_ship_speed_m_s"],
                                                      wave_heading_rad=math.radians(v["flexure_wave_heading_deg"]),
                                                      mode_freq_hz=tuple(v["flexure_hull_mode_freq_hz"]),
                                                      damping_ratio=tuple(v["flexure_hull_damping_ratio"]),
                                                      stations_m=tuple(v["flexure_lgu_stations_m"]))),
                platform_gyro=GyroParams(bias_sigma_deg_h=v["platform_gyro_bias_sigma_deg_h"],
                                         arw_deg_rt_h=v["platform_gyro_arw_deg_rt_h"],
                                         bias_instability_deg_h=v["platform_gyro_bi_deg_h"],
                                         bias_instability_tau_s=v["platform_gyro_bi_tau_s"],
                                         **_scale_errors(v, "platform_gyro", 3)),
                platform_accel=AccelerometerParams(bias_sigma_ug=v["platform_accel_bias_sigma_ug"],
                                                   noise_ug_rt_hz=v["platform_accel_noise_ug_rt_hz"],
                                                   **_scale_errors(v, "platform_accel", 3)),
                free_gyro_rate_hz=v["free_gyro_rate_hz"],
                free_gyro_site_deg=(v["free_gyro_site_lat_deg"], v["free_gyro_site_lon_deg"]),
                free_gyro=_free_gyro_params_from(v),
                resolver_rate_hz=v["resolver_rate_hz"],
                resolver=EncoderParams(noise_deg=v["resolver_noise_arcsec"] / 3600.0,
                                       lines_per_rev=2 ** v["resolver_bits"] if v["resolver_bits"] else 0,
                                       velocity_gate_s=v["resolver_velocity_gate_s"],
                                       cyclic_error_arcsec=v["resolver_cyclic_error_arcsec"],
                                       cyclic_harmonic=v["resolver_cyclic_harmonic"]),
                dtg=_dtg_params_from(v), dtg_lat_deg=v["dtg_lat_deg"],
            )
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc

    def decimation(self, rate_name: str) -> int:
        """Simulation steps per sample of the rate ``rate_name``; raises ``ValueError``
        naming it when it does not divide the simulation rate."""
        rate = getattr(self, rate_name)
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"{rate_name} must be > 0 Hz, got {rate}")
        ratio = self.sim_rate_hz / rate
        n = int(round(ratio))
        if n < 1 or abs(ratio - n) > 1e-9 * ratio:
            raise ValueError(f"{rate_name} = {rate} Hz does not divide sim_rate_hz = {self.sim_rate_hz} Hz")
        return n


class InsSample(NamedTuple):
    t: float
    euler: tuple[float, float, float]
    omega_b: tuple[float, float, float]
    true_gyro_bias: tuple[float, float, float]


class GimbalGyroSample(NamedTuple):
    t: float
    q_m: float
    r_m: float
    true_bias: tuple[float, float]


class JointReadout(NamedTuple):
    """Angles [rad] and rates [rad/s] of the named joints at ``t`` [s], as a joint sensor
    reads them (published as a sensor_msgs/JointState); each sensor its own subclass."""

    t: float
    names: tuple[str, ...]
    angles: tuple[float, ...]
    rates: tuple[float, ...]


class EncoderSample(JointReadout):
    """Gimbal encoder angles [rad] and rates [rad/s]."""

    __slots__ = ()


class LguSample(NamedTuple):
    """Increments [rad] accumulated over ``dt`` [s] ending at ``t``; flexure truth [rad]."""

    t: float
    dt: float
    dalpha1: tuple[float, float, float]
    dalpha2: tuple[float, float, float]
    flexure: tuple[float, float, float]
    flexure_quasi_static: tuple[float, float, float]


class ResolverSample(JointReadout):
    """Gimbal resolver angles [rad] (multi-turn azimuth) and tracking rates [rad/s]."""

    __slots__ = ()


class DtgSample(JointReadout):
    """The DTG pickoff angles [rad] (:data:`~gimbal_kinematics.maths.frames.DTG_PICKOFF_JOINTS`),
    no rates."""

    __slots__ = ()


class PlatformImuSample(NamedTuple):
    t: float
    specific_force: tuple[float, float, float]
    omega: tuple[float, float, float]
    true_accel_bias: tuple[float, float, float]
    true_gyro_bias: tuple[float, float, float]


def sensor_rng(seed: int, sensor: str) -> np.random.Generator:
    """The sensor's own stream, independent of which other sensors are enabled."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, zlib.crc32(sensor.encode())])


def _floats(values: Sequence[float]) -> tuple[float, ...]:
    return tuple(map(float, values))


class SensorSuite:
    """Feed :meth:`update` every simulation step's truth, in order; it returns the samples
    due at that step. Sample types: the ``*Sample`` named tuples of this module."""

    def __init__(self, config: SensorSuiteConfig) -> None:
        self.config = config
        dt = 1.0 / config.sim_rate_hz
        self._dt = dt
        on = set(config.sensors)
        self._dec = {SENSOR_RATES[s]: config.decimation(SENSOR_RATES[s]) for s in config.sensors}
        rng = lambda name: sensor_rng(config.seed, name)  # noqa: E731
        self.ins = InsModel(config.ins, rng("ins"), dt * self._dec["ins_rate_hz"]) if "ins" in on else None
        self.gimbal_gyro = (GyroModel(config.gimbal_gyro, 2, rng("gimbal_gyro"), dt * self._dec["gimbal_gyro_rate_hz"])
                            if "gimbal_gyro" in on else None)
        self.encoders = (EncoderModel(config.encoder, 3, rng("encoders"), dt * self._dec["encoder_rate_hz"])
                         if "encoders" in on else None)
        self.lgu = None
        if "lgu" in on:
            flexure = ShipFlexureTruth(config.flexure, rng("flexure"), dt)
            self.lgu = LguPair(flexure, rng("lgu"), dt, config.lgu1, config.lgu2)
            self._lgu_acc = [np.zeros(3), np.zeros(3)]
        self.platform_accel = self.platform_gyro = None
        if "platform_imu" in on:
            pdt = dt * self._dec["platform_imu_rate_hz"]
            self.platform_accel = AccelerometerModel(config.platform_accel, 3, rng("platform_accel"), pdt)
            self.platform_gyro = GyroModel(config.platform_gyro, 3, rng("platform_gyro"), pdt)
        self.free_gyro = None
        if "free_gyro" in on:
            self.free_gyro = FreeGyroSensor(config.free_gyro, rng("free_gyro"), dt * self._dec["free_gyro_rate_hz"])
            self._fg_site = tuple(math.radians(float(v)) for v in config.free_gyro_site_deg)
            self._fg_C = np.eye(3)  # body rotation since the last free-gyro sample
        self.resolvers = (EncoderModel(config.resolver, 4, rng("resolvers"), dt * self._dec["resolver_rate_hz"])
                          if "resolvers" in on else None)
        self.dtg = None
        if "dtg" in on:
            self.dtg = DtgOnPlatform(DtgPair(config.dtg, rng("dtg")), earth_rate_n(math.radians(config.dtg_lat_deg)),
                                     dt)
        self._last_k: int | None = None
        #: Steps that never arrived (the models bridge them with their nominal step).
        self.missed_steps = 0

    def update(self, truth: VehicleTruth, torquer_current_a: Sequence[float] | None = None) -> list[NamedTuple]:
        """Samples due at ``truth.k``. Steps must rise; a skipped step is counted in
        ``missed_steps``, and a step at or before the last one raises ``ValueError``.
        ``torquer_current_a``: with ``dtg``, the currents (x_s, y_s, z_s) [A] the servo
        commanded at the step before (needed from the second step on)."""
        k = truth.k
        if self._last_k is not None and k <= self._last_k:
            raise ValueError(f"truth step {k} out of order (last was {self._last_k})")
        self.missed_steps += k - (0 if self._last_k is None else self._last_k + 1)
        self._last_k = k
        out: list[NamedTuple] = []
        if self.lgu is not None and k > 0:
            d1, d2 = self.lgu.step(truth.delta_angle_b, self._dt)
            self._lgu_acc[0] += d1
            self._lgu_acc[1] += d2
        dec = self._dec
        due = lambda name: k % dec[name] == 0  # noqa: E731
        # The models return lists of Python floats: tuple() keeps them as they are.
        if self.ins is not None and due("ins_rate_hz"):
            euler, omega = self.ins.step(truth.euler, truth.omega_ib_b)
            out.append(InsSample(truth.t, _floats(euler), _floats(omega), self.ins.true_gyro_bias_values()))
        if self.gimbal_gyro is not None and due("gimbal_gyro_rate_hz"):
            if truth.omega_im_m is None:
                raise ValueError("gimbal_gyro needs the two_axis_gimbal plant")
            q_m, r_m = self.gimbal_gyro.step_rate(truth.omega_im_m[1:])
            out.append(GimbalGyroSample(truth.t, float(q_m), float(r_m), self.gimbal_gyro.true_bias_values()))
        if self.encoders is not None and due("encoder_rate_hz"):
            if len(truth.joint_position) != 3:
                raise ValueError("encoders need the two_axis_gimbal plant")
            angles, rates = self.encoders.step(truth.joint_position)
            out.append(EncoderSample(truth.t, truth.joint_names, tuple(angles), tuple(rates)))
        if self.lgu is not None and k > 0 and due("lgu_rate_hz"):
            flex = self.lgu.flexure
            out.append(LguSample(truth.t, self._dt * self._dec["lgu_rate_hz"], _floats(self._lgu_acc[0]),
                                 _floats(self._lgu_acc[1]), _floats(flex.angle),
                                 _floats(flex.quasi_static_angle(flex.t))))
            self._lgu_acc = [np.zeros(3), np.zeros(3)]
        if self.resolvers is not None and due("resolver_rate_hz"):  # before the IMU: servos read angles first
            if len(truth.joint_position) != 4:
                raise ValueError("resolvers need the four_gimbal_platform plant")
            angles, rates = self.resolvers.step(truth.joint_position)
            out.append(ResolverSample(truth.t, truth.joint_names, _floats(angles), _floats(rates)))
        if self.platform_accel is not None and due("platform_imu_rate_hz"):
            if truth.specific_force_m is None or len(truth.joint_position) != 4:
                raise ValueError("platform_imu needs the four_gimbal_platform plant")
            f = self.platform_accel.step(truth.specific_force_m)
            w = self.platform_gyro.step_rate(truth.omega_im_m)
            out.append(PlatformImuSample(truth.t, _floats(f), _floats(w), _floats(self.platform_accel.true_bias),
                                         _floats(self.platform_gyro.true_bias)))
        if self.free_gyro is not None:
            out.extend(self._free_gyro_update(truth, due("free_gyro_rate_hz")))
        if self.dtg is not None:
            if truth.quat_nm is None or truth.specific_force_m is None or len(truth.joint_position) != 4:
                raise ValueError("dtg needs the four_gimbal_platform plant")
            out.append(DtgSample(truth.t, DTG_PICKOFF_JOINTS,
                                 self.dtg.update(truth.quat_nm, truth.specific_force_m, torquer_current_a), ()))
        return out

    def _free_gyro_update(self, truth: VehicleTruth, due: bool) -> list[FreeGyroSample]:
        """Accumulate the body rotation every step; at a sample, the triad gets its rotation
        vector over the interval divided by the interval (the step-average rate; at k = 0,
        with no interval behind it, the instantaneous rate)."""
        if truth.delta_angle_b is None or truth.omega_ib_b is None:
            raise ValueError("free_gyro needs /truth/host/imu and /truth/host/delta_angle")
        if truth.k > 0:
            self._fg_C = self._fg_C @ dcm_from_rotation_vector(np.asarray(truth.delta_angle_b, dtype=float))
        if not due:
            return []
        interval = self._dt * self._dec["free_gyro_rate_hz"]
        rate = rotation_vector_from_dcm(self._fg_C) / interval if truth.k > 0 else np.asarray(truth.omega_ib_b)
        self._fg_C = np.eye(3)
        lat, lon = self._fg_site
        return [self.free_gyro.update(truth.t, lat, lon, truth.euler, rate, interval)]
