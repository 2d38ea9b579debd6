"""gimbal-allan and Kalibr's IMU noise file (``imu.yaml``), and allan_variance_ros's.

* Round trip: a bag (written by ``rosbags``) of a gyro and an accelerometer with white noise
  and a bias random walk → ``gimbal-allan --kalibr imu.yaml`` → ``--from-kalibr imu.yaml``:
  the filters' parameters are the ones gimbal-allan wrote from the bag, within 1e-12. The
  file loads the way Kalibr's own reader (``kalibr_common/ConfigReader.py``, ImuParameters)
  loads it: ``yaml.safe_load``, its four keys as numbers > 0, ``rostopic`` a string,
  ``update_rate`` > 0.
* Kalibr's documentation example (the ADIS16448 ``imu.yaml`` of the Kalibr wiki, "YAML
  formats": https://github.com/ethz-asl/kalibr/wiki/yaml-formats) loads with the values the
  documentation states, converted here with ``math.degrees`` to the parameters' units.
* allan_variance_ros's README example (https://github.com/ori-drs/allan_variance_ros, "Kalibr")
  loads the same way, and its placeholder topic and rate are reported.
* Bad files and bad combinations are refused (exit 2) naming the option, writing nothing.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
from allan_bags import write_imu_bag  # noqa: E402

from gimbal_sim.allan.cli import main  # noqa: E402

RATE_HZ = 100.0
N_MSG = 20000  # 200 s
UG = 9.80665e-6

# Kalibr wiki, "YAML formats", IMU configuration (imu.yaml), the ADIS16448 example
KALIBR_EXAMPLE = """\
#Accelerometers
accelerometer_noise_density: 1.86e-03   #Noise density (continuous-time)
accelerometer_random_walk:   4.33e-04   #Bias random walk

#Gyroscopes
gyroscope_noise_density:     1.87e-04   #Noise density (continuous-time)
gyroscope_random_walk:       2.66e-05   #Bias random walk

rostopic:                    /imu0      #the IMU ROS topic
update_rate:                 200.0      #Hz (for discretization of the values above)
"""
# allan_variance_ros README, "Kalibr": the imu.yaml its analysis.py writes
AVR_EXAMPLE = """\
#Accelerometer
accelerometer_noise_density: 0.006308226052016165 
accelerometer_random_walk: 0.00011673723527962174 

#Gyroscope
gyroscope_noise_density: 0.00015198973532354657 
gyroscope_random_walk: 2.664506559330434e-06 

rostopic: '/sensors/imu' #Make sure this is correct
update_rate: 400.0 #Make sure this is correct

"""


def _series(rng, white: float, walk: float) -> np.ndarray:
    dt = 1.0 / RATE_HZ
    return (white / math.sqrt(dt) * rng.standard_normal((N_MSG, 3))
            + np.cumsum(walk * math.sqrt(dt) * rng.standard_normal((N_MSG, 3)), axis=0))


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    rng = np.random.default_rng(3)
    stamps = 1_700_000_000_000_000_000 + np.arange(N_MSG, dtype=np.int64) * int(1e9 / RATE_HZ)
    gyro = _series(rng, 1e-3, 3e-4)  # rad/√s, rad/s/√s
    accel = _series(rng, 2e-3, 6e-4) + np.array([0.0, 0.0, 9.8])
    return write_imu_bag(tmp_path_factory.mktemp("kalibr") / "bag", stamps, gyro, accel=accel)


def _run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _params(path: Path) -> dict[str, float]:
    return {f"{node}.{k}": v for node, body in yaml.safe_load(path.read_text()).items()
            for k, v in body["ros__parameters"].items()}


def _sensor_models(path: Path) -> dict[str, float]:
    return yaml.safe_load(path.read_text())["sensor_models"]["ros__parameters"]


def test_round_trip_through_kalibr_gives_the_same_parameters(bag, tmp_path, capsys):
    imu = tmp_path / "imu.yaml"
    code, _, err = _run(capsys, bag, "--topic", "/imu", "--out", tmp_path / "a", "--kalibr", imu, "--no-progress")
    assert code == 0, err
    # Kalibr's reader: safe_load, four positive numbers, a topic string, a positive rate
    doc = yaml.safe_load(imu.read_text())
    for key in ("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
                "gyroscope_random_walk"):
        assert isinstance(doc[key], float) and doc[key] > 0.0, key
    assert doc["rostopic"] == "/imu" and doc["update_rate"] == pytest.approx(RATE_HZ)
    # the gyro density is the largest white noise over the axes (allan.json, deg/√h)
    axes = json.loads((tmp_path / "a" / "allan.json").read_text())["axes"].values()
    arw = max(a["arw_deg_rt_h"] for a in axes)
    assert doc["gyroscope_noise_density"] == pytest.approx(math.radians(arw) / 60.0, rel=1e-12)
    assert 0.8e-3 < doc["gyroscope_noise_density"] < 1.2e-3 and 1.6e-3 < doc["accelerometer_noise_density"] < 2.4e-3

    direct = _params(tmp_path / "a" / "filters.yaml")
    tau = direct["gyro_bias_ekf.gyro_bias_tau_s"]
    code, _, err = _run(capsys, "--from-kalibr", imu, "--out", tmp_path / "b", "--bias-tau-s", tau)
    assert code == 0, err
    back = _params(tmp_path / "b" / "filters.yaml")
    assert back.keys() == direct.keys()
    for key, value in direct.items():
        assert back[key] == pytest.approx(value, rel=1e-12, abs=0.0), key
    sim = _sensor_models(tmp_path / "b" / "sensor_models.yaml")
    assert sim["platform_accel_noise_ug_rt_hz"] == pytest.approx(doc["accelerometer_noise_density"] / UG, rel=1e-12)


def test_kalibrs_documentation_example_loads_with_its_stated_values(tmp_path, capsys):
    path = tmp_path / "imu_adis16448.yaml"
    path.write_text(KALIBR_EXAMPLE)
    code, _, err = _run(capsys, "--from-kalibr", path, "--out", tmp_path / "o")
    assert code == 0, err
    sim = _sensor_models(tmp_path / "o" / "sensor_models.yaml")
    assert sim["gimbal_gyro_arw_deg_rt_h"] == pytest.approx(math.degrees(1.87e-04) * 60.0, rel=1e-12)
    assert sim["gimbal_gyro_rrw_deg_h_rt_h"] == pytest.approx(math.degrees(2.66e-05) * 3600.0 * 60.0, rel=1e-12)
    assert sim["gimbal_gyro_bi_deg_h"] == 0.0 and sim["gimbal_gyro_quantum_deg"] == 0.0  # not in Kalibr's model
    assert sim["platform_accel_noise_ug_rt_hz"] == pytest.approx(1.86e-03 / UG, rel=1e-12)
    filters = _params(tmp_path / "o" / "filters.yaml")
    assert filters["encoder_fusion_controller.kf_q_angle_deg_rt_s"] == pytest.approx(math.degrees(1.87e-4), rel=1e-12)
    assert filters["encoder_fusion_controller.kf_q_drift_deg_s_rt_s"] == pytest.approx(math.degrees(2.66e-5),
                                                                                       rel=1e-12)
    # gyro_bias_ekf's own default tau (100 s), its Gauss-Markov PSD 2 sigma^2 / tau = the walk's
    sigma = math.radians(filters["gyro_bias_ekf.gyro_bias_instability_deg_h"] / 3600.0)
    assert filters["gyro_bias_ekf.gyro_bias_tau_s"] == 100.0
    assert 2.0 * sigma**2 / 100.0 == pytest.approx(2.66e-05**2, rel=1e-12)
    set_args = (tmp_path / "o" / "set_args.txt").read_text()
    assert f"--set sensor_models.gimbal_gyro_arw_deg_rt_h={sim['gimbal_gyro_arw_deg_rt_h']!r}" in set_args


def test_allan_variance_ros_example_loads_and_its_placeholders_are_said(tmp_path, capsys):
    path = tmp_path / "imu.yaml"
    path.write_text(AVR_EXAMPLE)
    code, _, err = _run(capsys, "--from-allan-variance-ros", path, "--out", tmp_path / "o", "--simulate-as",
                        "ins_gyro")
    assert code == 0, err
    assert "placeholders" in err and "/sensors/imu" in err
    sim = _sensor_models(tmp_path / "o" / "sensor_models.yaml")
    assert sim["ins_gyro_arw_deg_rt_h"] == pytest.approx(math.degrees(0.00015198973532354657) * 60.0, rel=1e-12)
    assert sim["platform_accel_noise_ug_rt_hz"] == pytest.approx(0.006308226052016165 / UG, rel=1e-12)
    assert _params(tmp_path / "o" / "filters.yaml")["gyro_bias_ekf.roll_bias_tau_s"] == 60.0  # the INS channel


@pytest.mark.parametrize("text, words", [
    (KALIBR_EXAMPLE.replace("gyroscope_random_walk:       2.66e-05", ""), "gyroscope_random_walk is missing"),
    (KALIBR_EXAMPLE.replace("1.86e-03", "-1.86e-03"), "accelerometer_noise_density must be a number > 0"),
    (KALIBR_EXAMPLE.replace("200.0", "fast"), "update_rate must be a number > 0"),
    ("accelerometer_noise_density: [1, 2\n", "not YAML"),
    ("- 1\n- 2\n", "not a Kalibr IMU file"),
])
def test_bad_kalibr_files_are_refused_naming_the_key(tmp_path, capsys, text, words):
    path = tmp_path / "imu.yaml"
    path.write_text(text)
    code, _, err = _run(capsys, "--from-kalibr", path, "--out", tmp_path / "o")
    assert code == 2 and "--from-kalibr" in err and words in err and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


def test_bad_combinations_are_refused_and_nothing_is_written(bag, tmp_path, capsys):
    code, _, err = _run(capsys, "--from-kalibr", tmp_path / "none.yaml", "--out", tmp_path / "o")
    assert code == 2 and "none.yaml" in err
    code, _, err = _run(capsys, bag, "--from-kalibr", tmp_path / "none.yaml", "--out", tmp_path / "o")
    assert code == 2 and "BAG" in err and "not with --from-kalibr" in err
    code, _, err = _run(capsys, "--out", tmp_path / "o")
    assert code == 2 and "BAG" in err and "required" in err
    taken = tmp_path / "taken.yaml"
    taken.write_text("x: 1\n")
    code, _, err = _run(capsys, bag, "--topic", "/imu", "--out", tmp_path / "o", "--kalibr", taken)
    assert code == 2 and "--kalibr" in err and "not overwriting" in err
    # a gyro-only bag has no accelerometer for Kalibr's file (REP 145: not provided)
    stamps = 1_700_000_000_000_000_000 + np.arange(6000, dtype=np.int64) * int(1e9 / RATE_HZ)
    gyro_only = write_imu_bag(tmp_path / "gyro_only", stamps, np.random.default_rng(1).standard_normal((6000, 3)))
    code, _, err = _run(capsys, gyro_only, "--topic", "/imu", "--out", tmp_path / "o", "--kalibr",
                        tmp_path / "k.yaml", "--no-progress")
    assert code == 2 and "--kalibr" in err and "linear_acceleration" in err, err
    assert not (tmp_path / "o").exists() and not (tmp_path / "k.yaml").exists()
