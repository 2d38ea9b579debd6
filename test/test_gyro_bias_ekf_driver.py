"""Acceptance: ``gyro_bias_ekf`` started alone from its executable with a params
YAML, in free timing (its default outside gimbal-run), against a driver the project did not
write (``driver_publisher.py``: plain rclpy + sensor_msgs, wall-clock stamps): gimbal gyro
at 200 Hz ± 20 % jitter with 100 °/h bias per axis plus white noise, encoders at 100 Hz,
INS at 50 Hz with 2 % of samples dropped. Once with ``qos_profile_sensor_data``, once with
the default QoS, both at once in two ROS domains (60 s of data: real time is the point).

Observability: the host is static and the gimbal held, so the gyro's (q, r) bias makes the
propagated attitude drift linearly, by C_nm (δb_q, δb_r) t, while the measured attitude
(INS Euler angles + encoders, paper 1 §3) does not move; the drift is therefore observed
directly, with INS attitude errors (white here) and encoder noise averaging down over the
60 s. The truth: the injected 100 °/h on q and r, zero on the roll channel (exact INS
rates)."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import VENV_BIN, _claimed_env
from gimbal_sim.graph.orchestrator import stop_processes

pytestmark = [pytest.mark.ros, pytest.mark.slow]

HERE = Path(__file__).resolve().parent
DEG_H = math.pi / 180.0 / 3600.0
DURATION_S = 60.0

PARAMS_YAML = """\
gyro_bias_ekf:
  ros__parameters:
    lat_deg: 45.0
    gyro_arw_deg_rt_h: 0.15
    gyro_bias_sigma_deg_h: 200.0
    gyro_bias_instability_deg_h: 1.0
    gyro_bias_tau_s: 1000.0
    encoder_noise_deg: 0.01
    diagnostics_period_s: 1.0
"""


@pytest.fixture(scope="module")
def driver_runs(tmp_path_factory):
    """Both QoS cases at once, each in a domain of its own; returns {qos: results}."""
    tmp = tmp_path_factory.mktemp("driver")
    params = tmp / "gyro_bias_ekf.yaml"
    params.write_text(PARAMS_YAML)
    procs, claims, logs, outs = [], [], [], {}
    try:
        for i, qos in enumerate(("sensor_data", "default")):
            env, claim = _claimed_env()
            claims.append(claim)
            log = open(tmp / f"{qos}.log", "w")
            logs.append(log)
            procs.append(subprocess.Popen([str(VENV_BIN / "gyro_bias_ekf"), "--ros-args", "--params-file", str(params)],
                                          env=env, stdout=log, stderr=subprocess.STDOUT))
            outs[qos] = tmp / f"{qos}.json"
            procs.append(subprocess.Popen([sys.executable, str(HERE / "driver_publisher.py"), str(outs[qos]),
                                           "--qos", qos, "--duration-s", str(DURATION_S), "--seed", str(10 + i)],
                                          env=env, stdout=log, stderr=subprocess.STDOUT))
        for p in procs[1::2]:
            p.wait(timeout=DURATION_S + 240)
    finally:
        stop_processes(procs)
        for log in logs:
            log.close()
        for claim in claims:
            claim.release()
    results = {}
    for qos, path in outs.items():
        assert path.is_file(), (tmp / f"{qos}.log").read_text()[-3000:]
        results[qos] = json.loads(path.read_text())
    return results


@pytest.mark.parametrize("qos", ["sensor_data", "default"])
def test_bias_estimate_within_3_sigma_and_10_deg_h_after_60_s(driver_runs, qos):
    r = driver_runs[qos]
    bias = np.array(r["bias"])
    sigma_by_stamp = {int(row[0]): row for row in r["sigma"]}
    assert len(bias) and len(sigma_by_stamp) >= 0.9 * len(bias)  # the driver may miss a few outputs
    # nearly every INS sample gets an estimate: best effort may lose a few inputs on a loaded
    # 2-core machine, and this Python driver, busy publishing on schedule, some outputs
    diag = r["diagnostics"][0]
    assert len(bias) >= 0.9 * r["counts"]["ins"], (len(bias), r["counts"], diag)
    assert int(diag["updates"]) >= 0.9 * r["counts"]["ins"], (r["counts"], diag)
    # the estimate after 60 s of data (the last with its sigma), stamped like its INS sample
    last = max(int(b[0]) for b in r["bias"] if int(b[0]) in sigma_by_stamp)  # ints: ns near 1.8e18
    assert last >= r["start_ns"] + (DURATION_S - 0.2) * 1e9
    row = next(b for b in r["bias"] if int(b[0]) == last)
    truth = np.array([0.0, r["bias_rad_s"], r["bias_rad_s"]])
    err, sd = np.array(row[1:]) - truth, np.array(sigma_by_stamp[last][1:])
    print(f"{qos}: bias error (q, r) = {err[1:] / DEG_H} deg/h, sigma = {sd[1:] / DEG_H} deg/h")
    assert np.all(np.abs(err[1:]) <= 3.0 * sd[1:]), (err / DEG_H, sd / DEG_H)
    assert np.all(np.abs(err[1:]) <= 10.0 * DEG_H), err / DEG_H
    assert abs(err[0]) <= 3.0 * sd[0]


@pytest.mark.parametrize("qos", ["sensor_data", "default"])
def test_diagnostics_count_the_dropped_ins_samples_and_report_nis(driver_runs, qos):
    r = driver_runs[qos]
    (diag,) = r["diagnostics"]
    # the INS runs on an exact 20 ms grid here, so every drop is a 2-period gap; the last
    # diagnostics message may precede the last few drops, and best effort may lose a few more
    dropped = r["counts"]["ins_dropped"]
    lost = r["counts"]["ins"] - int(diag["ins_received"])
    assert dropped - 3 <= int(diag["ins_dropped"]) <= dropped + max(lost, 0) + 3, (diag, r["counts"])
    assert int(diag["incompatible_qos"]) == 0
    for key in ("gyro_not_provided", "ins_rates_not_provided", "joint_names_missing", "gyro_duplicates",
                "gyro_out_of_order"):
        assert int(diag[key]) == 0, (key, diag)
    assert diag["nis_verdict"] in ("consistent", "conservative", "overconfident")
    lo, hi, mean = float(diag["nis_lower_95"]), float(diag["nis_upper_95"]), float(diag["nis_mean"])
    print(f"{qos}: NIS mean {mean:.3f} in [{lo:.3f}, {hi:.3f}] over {diag['nis_window']}: {diag['nis_verdict']}")
    assert lo < 3.0 < hi
