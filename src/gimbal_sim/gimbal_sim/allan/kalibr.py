"""Kalibr's IMU noise file (``imu.yaml``), written from a characterisation and read back, and
the one allan_variance_ros writes, read into this toolkit's parameter files.

Kalibr's model (its wiki, "IMU Noise Model") is white noise plus a bias random walk, per axis,
in continuous time:

    gyroscope_noise_density      σ_g   [rad/s/√Hz]    = the angle random walk N [rad/√s]
    gyroscope_random_walk        σ_bg  [rad/s²/√Hz]   bias walk density, sqrt of its PSD
    accelerometer_noise_density  σ_a   [m/s²/√Hz]     = the velocity random walk [m/s/√s]
    accelerometer_random_walk    σ_ba  [m/s³/√Hz]
    update_rate [Hz], rostopic

Discrete and continuous (the confusion of kalibr issue #354): the file holds the continuous
densities. Sampled every Δt = 1/update_rate, the white noise of one sample has σ_g/√Δt [rad/s]
and the bias steps by σ_bg·√Δt [rad/s] per sample; Kalibr divides by √Δt itself. The
densities are what the Allan deviation shows (N at τ = 1 s on the −1/2 slope, K at τ = 3 s on
the +1/2 slope), and they are what this toolkit's parameters hold too: ``sensor_models``
(``*_arw_deg_rt_h``, ``*_rrw_deg_h_rt_h``) and the filters take continuous densities and
discretise them with their own step. Never put a per-sample σ into either.

Written from a characterisation: the noise density is the white term, the random walk is
sqrt(q_b), the bias walk PSD the filters use (:func:`.params.bias_walk_psd`: a Gauss-Markov
term counts as 2σ²/T, its walk at lags under T; Kalibr has no Gauss-Markov term), each the
largest over the axes (Kalibr is an estimator: told less noise than an axis has it would be
overconfident on that axis, the rule :mod:`.params` gives the filters). A rate ramp and a
quantisation have no place in Kalibr's model and are left out. Kalibr refuses a
value ≤ 0, so a term no axis detected is written as the largest 1σ an axis could have had
(its detection bound), said in the file's comments and on stderr.

Kalibr's noise file has no scale factor or misalignment (``kalibr_calibrate_imu_camera
--imu-models scale-misalignment`` estimates them with a camera, apart from this file): the data
sheet's figures, when given (:data:`.params.DATASHEET`), are written as comments of the export
and as ``sensor_models`` parameters of the files read back.

Read back: the white noise and the walk become the ``sensor_models`` parameters of a sensor
with exactly that model (no Gauss-Markov, no quantisation) and the filters' parameters, with
``gyro_bias_ekf``'s bias correlation time ``bias_tau_s`` (its PSD 2σ²/τ is the file's σ_bg²).
allan_variance_ros writes the same names and units from its own Allan deviation (the white
line read at τ = 1 s, the walk line at τ = 3 s, the worst axis); its ``rostopic`` and
``update_rate`` are placeholders unless it was given its config file, which it marks with
"Make sure this is correct".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from gimbal_estimators.gyro_bias_ekf_params import PARAMS as EKF_PARAMS
from gimbal_kinematics.cli.boundary import UsageError
from gimbal_kinematics.maths.units import DEG, UG

from .analyze import Characterisation
from .params import (DATASHEET, GYRO_TARGETS, datasheet_header, datasheet_params, filter_noise,
                     gyro_filter_params, ros_params_yaml, set_arguments)

#: Kalibr's keys, in the order its documentation's example lists them, with their units.
KEYS = {"accelerometer_noise_density": "m/s^2/sqrt(Hz)", "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
        "gyroscope_noise_density": "rad/s/sqrt(Hz)", "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"}
PLACEHOLDER_MARK = "Make sure this is correct"


@dataclass
class KalibrImu:
    """The contents of a Kalibr ``imu.yaml`` (SI, continuous time: module docstring)."""

    accelerometer_noise_density: float
    accelerometer_random_walk: float
    gyroscope_noise_density: float
    gyroscope_random_walk: float
    rostopic: str
    update_rate: float
    #: what the numbers do not say: bounds written for undetected terms, placeholders read
    notes: list[str] = field(default_factory=list)


def _bound(result: Characterisation, name: str) -> float:
    """The largest 1σ an axis could have had for a term it did not detect."""
    return max((r.fit.terms[name].sigma for r in result.axes.values() if not r.dead), default=0.0)


def from_characterisations(gyro: Characterisation, accel: Characterisation) -> KalibrImu:
    """The Kalibr file of the gyro and accelerometer characterisations of one IMU topic: the
    white density and sqrt(q_b) the filters get (:func:`.params.filter_noise`)."""
    values, notes = {}, []
    for prefix, result in (("gyroscope", gyro), ("accelerometer", accel)):
        white, q_b, _ = filter_noise(result)
        for key, value, term in ((f"{prefix}_noise_density", white, "white"),
                                 (f"{prefix}_random_walk", math.sqrt(q_b), "rrw")):
            if not value > 0.0:
                value = _bound(result, term)
                notes.append(f"{key}: not detected on any axis; written as its largest 1-sigma bound "
                             f"{value:.3g} (Kalibr refuses 0)")
            if not value > 0.0:
                raise UsageError(f"--kalibr: {key}: no axis gives a value or a bound (a dead sensor?); Kalibr "
                                 f"needs one > 0")
            values[key] = value
    return KalibrImu(**values, rostopic=gyro.topic, update_rate=gyro.sample_rate_hz, notes=notes)


def kalibr_yaml(imu: KalibrImu, source: str, datasheet: dict[str, float | None] | None = None) -> str:
    """The ``imu.yaml`` text: Kalibr's keys and layout, continuous-time values, full precision;
    the data sheet's scale-factor and misalignment figures given, as comments (module docstring)."""
    lines = [f"# Kalibr IMU noise model written by gimbal-allan from {source}: continuous-time densities",
             "# (per-sample white noise = density * sqrt(update_rate); per-sample bias step = random_walk /",
             "# sqrt(update_rate)); each the largest over the axes."]
    lines += [f"# NOTE {n}" for n in imu.notes]
    given = {k: v for k, v in (datasheet or {}).items() if v is not None}
    if given:
        lines += ["# Gyro data sheet, not in Kalibr's noise model (its scale-misalignment IMU model estimates",
                  "# them): " + ", ".join(f"{DATASHEET[k][1]} {v:g}" for k, v in given.items())]
    for key, unit in KEYS.items():
        if key.startswith("accelerometer_noise"):
            lines.append("#Accelerometers")
        elif key.startswith("gyroscope_noise"):
            lines.append("#Gyroscopes")
        lines.append(f"{key}: {getattr(imu, key)!r}   # [{unit}]")
    lines += [f"rostopic: {imu.rostopic}   # the IMU ROS topic",
              f"update_rate: {imu.update_rate!r}   # [Hz] the recorded rate (for discretization of the values above)"]
    return "\n".join(lines) + "\n"


def read_kalibr(path: Path, option: str) -> KalibrImu:
    """A Kalibr-format ``imu.yaml`` (Kalibr's own, or allan_variance_ros's). Refuses (naming
    ``option`` and the key) a missing key or a value Kalibr would refuse (≤ 0, not a number)."""
    text = Path(path).read_text()
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise UsageError(f"{option}: {path}: not YAML ({' '.join(str(exc).split())})") from exc
    if not isinstance(data, dict):
        raise UsageError(f"{option}: {path}: not a Kalibr IMU file (a YAML mapping of {', '.join(KEYS)})")
    values, notes = {}, []
    for key in (*KEYS, "update_rate"):
        value = data.get(key)
        if value is None:
            raise UsageError(f"{option}: {path}: {key} is missing")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise UsageError(f"{option}: {path}: {key} must be a number > 0 (Kalibr refuses it), got {value!r}")
        values[key] = float(value)
    topic = data.get("rostopic")
    if not isinstance(topic, str) or not topic:
        raise UsageError(f"{option}: {path}: rostopic must be a topic name, got {topic!r}")
    if PLACEHOLDER_MARK in text:
        notes.append(f"the file marks rostopic ({topic}) and update_rate ({values['update_rate']:g} Hz) as "
                     f"placeholders ('{PLACEHOLDER_MARK}'); the densities do not depend on them")
    return KalibrImu(**values, rostopic=topic, notes=notes)


def sensor_models_params(imu: KalibrImu, target: str) -> dict:
    """``sensor_models`` parameters of a sensor with exactly Kalibr's model: the gyro as
    ``target``, the accelerometer as the platform accelerometer (white noise, its one noise
    parameter)."""
    if target not in GYRO_TARGETS:
        raise UsageError(f"--simulate-as {target!r}: a Kalibr gyro can be simulated as {sorted(GYRO_TARGETS)}")
    p = GYRO_TARGETS[target]
    return {f"{p}_arw_deg_rt_h": imu.gyroscope_noise_density * 60.0 / DEG,
            f"{p}_bi_deg_h": 0.0,
            f"{p}_rrw_deg_h_rt_h": imu.gyroscope_random_walk * 3600.0 * 60.0 / DEG,
            f"{p}_quantum_deg": 0.0,
            "platform_accel_noise_ug_rt_hz": imu.accelerometer_noise_density / UG}


def filter_params(imu: KalibrImu, target: str, bias_tau_s: float) -> dict[str, dict]:
    """The filters' noise parameters of the file's gyro (:func:`.params.gyro_filter_params`)."""
    return gyro_filter_params(imu.gyroscope_noise_density, imu.gyroscope_random_walk**2, bias_tau_s, target)


def default_bias_tau_s(target: str) -> float:
    """``gyro_bias_ekf``'s own default correlation time for the channel ``target`` feeds."""
    name = "gyro_bias_tau_s" if target == "gimbal_gyro" else "roll_bias_tau_s"
    return float(next(p.default for p in EKF_PARAMS if p.name == name))


def parameter_files(imu: KalibrImu, target: str, bias_tau_s: float, source: str,
                    datasheet: dict[str, float | None] | None = None) -> dict[str, str]:
    """``sensor_models.yaml``, ``filters.yaml`` and ``set_args.txt`` of a Kalibr file: name -> text;
    the gyro's data-sheet scale-factor and misalignment figures given in the first and last."""
    sim = {**sensor_models_params(imu, target), **datasheet_params(target, datasheet)}
    head = [f"from the Kalibr IMU noise file {source} (continuous-time densities; rostopic {imu.rostopic},",
            f"update_rate {imu.update_rate:g} Hz), by gimbal-allan."] + [f"NOTE {n}" for n in imu.notes]
    return {
        "sensor_models.yaml": ros_params_yaml(
            ["sensor_models parameters " + head[0], *head[1:],
             f"Kalibr's model is white noise plus a bias random walk: {target} gets exactly that (no Gauss-Markov",
             "bias, no quantisation); the accelerometer's white noise goes to the platform accelerometer.",
             *datasheet_header(datasheet)],
            {"sensor_models": sim}),
        "filters.yaml": ros_params_yaml(
            ["Filter noise parameters " + head[0], *head[1:],
             "The bias walk PSD q_b = gyroscope_random_walk^2: gyro_bias_ekf uses 2 sigma^2 / tau = q_b with",
             f"tau = {bias_tau_s:g} s (--bias-tau-s); flexure_estimator's LGU bias difference walks with 2 q_b;",
             "encoder_fusion_controller's drift density is sqrt(q_b)."],
            filter_params(imu, target, bias_tau_s)),
        "set_args.txt": " ".join(set_arguments(sim)) + "\n",
    }
