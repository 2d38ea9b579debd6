"""gimbal-allan's input handling: bags written by rosbags (MCAP and sqlite3), REP 145 fields
and axes, sampling breaks, non-finite samples, and every refusal (exit 2, naming the
argument, nothing overwritten)."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from allan_bags import write_imu_bag  # noqa: E402

from gimbal_sim.allan.cli import main  # noqa: E402

RATE_HZ = 100.0
N_MSG = 6000  # 60 s
EPOCH_NS = 1_700_000_000_000_000_000
ARW = 1e-3  # rad/√s


def _stamps(n: int = N_MSG) -> np.ndarray:
    return EPOCH_NS + np.arange(n, dtype=np.int64) * int(1e9 / RATE_HZ)


def _gyro(n: int = N_MSG, seed: int = 0) -> np.ndarray:
    return ARW * math.sqrt(RATE_HZ) * np.random.default_rng(seed).standard_normal((n, 3)) + 7e-5


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    return write_imu_bag(tmp_path_factory.mktemp("allan") / "bag", _stamps(), _gyro(),
                         extra_topics={"/vec": "geometry_msgs/msg/Vector3Stamped"})


def _run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_help_says_what_it_does(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "Allan deviation" in text and "IEEE Std 952" in text and "--topic" in text


def test_a_plain_bag_gives_every_output(bag, tmp_path, capsys):
    out = tmp_path / "out"
    code, stdout, _ = _run(capsys, bag, "--topic", "/imu", "--out", out, "--json", tmp_path / "a.json",
                           "--no-progress")
    assert code == 0, stdout
    doc = json.loads((out / "allan.json").read_text())
    assert json.loads((tmp_path / "a.json").read_text()) == doc
    assert doc["topic"] == "/imu" and doc["field"] == "angular_velocity"
    assert doc["sample_rate_hz"] == pytest.approx(RATE_HZ) and doc["duration_s"] == pytest.approx(N_MSG / RATE_HZ)
    assert set(doc["axes"]) == {"x", "y", "z"} and doc["skipped_axes"] == {}
    for axis in doc["axes"].values():  # an all-zero covariance is "unknown": the data are used
        assert axis["arw_deg_rt_h"] == pytest.approx(ARW * 60 * 180 / math.pi, rel=0.1)
        for key in ("arw_sigma", "bias_instability_deg_h", "bias_tau_s", "rrw_deg_h_rt_h", "quantization_deg",
                    "rate_ramp_deg_h2", "flicker_floor_deg_h"):
            assert key in axis
    for name in ("adev_x.png", "adev_y.png", "adev_z.png", "sensor_models.yaml", "filters.yaml", "set_args.txt"):
        assert (out / name).stat().st_size > 0
    # nothing is overwritten: a second run into the same directory is refused, the files stay
    before = (out / "allan.json").read_bytes()
    code, _, err = _run(capsys, bag, "--topic", "/imu", "--out", out, "--no-progress")
    assert code == 2 and "--out" in err and "not overwriting" in err
    assert (out / "allan.json").read_bytes() == before


@pytest.mark.parametrize("argv, option, words", [
    (["--topic", "/nope"], "--topic", "not in the bag"),
    (["--topic", "/vec"], "--topic", "geometry_msgs/msg/Vector3Stamped"),
    (["--topic", "/imu", "--field", "linear_acceleration"], "--field", "REP 145"),
    (["--topic", "/imu", "--tau-max-s", "10"], "--tau-max-s", "10 x the longest tau"),
    (["--topic", "/imu", "--tau-max-s", "-1"], "--tau-max-s", "must be > 0"),
    (["--topic", "/imu", "--simulate-as", "platform_accel"], "--simulate-as", "cannot simulate"),
])
def test_bad_requests_are_refused_naming_the_option(bag, tmp_path, capsys, argv, option, words):
    code, _, err = _run(capsys, bag, *argv, "--out", tmp_path / "o", "--no-progress")
    assert code == 2 and option in err and words in err, err
    assert not (tmp_path / "o").exists()


def test_missing_unclosed_and_truncated_bags_are_refused(bag, tmp_path, capsys):
    code, _, err = _run(capsys, tmp_path / "none", "--topic", "/imu", "--out", tmp_path / "o")
    assert code == 2 and "no such file" in err
    unclosed = tmp_path / "unclosed"
    unclosed.mkdir()
    mcap = next(bag.glob("*.mcap"))
    (unclosed / mcap.name).write_bytes(mcap.read_bytes())
    code, _, err = _run(capsys, unclosed, "--topic", "/imu", "--out", tmp_path / "o")
    assert code == 2 and "not closed cleanly" in err and "gimbal-bag recover" in err
    cut = tmp_path / "cut"
    cut.mkdir()
    (cut / "metadata.yaml").write_text((bag / "metadata.yaml").read_text())
    (cut / mcap.name).write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    code, _, err = _run(capsys, cut, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 2 and ("truncated" in err or "cannot read" in err)
    assert not (tmp_path / "o").exists()


def test_unmeasured_axis_is_skipped_and_refused_when_asked_for(tmp_path, capsys):
    # a two-axis gyro: x = 0 with a very large variance on its diagonal element (SPEC §2)
    g = _gyro()
    g[:, 0] = 0.0
    cov = np.diag([1e9, 1e-6, 1e-6]).ravel()
    b = write_imu_bag(tmp_path / "two_axis", _stamps(), g, gyro_cov=cov)
    code, _, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert set(doc["axes"]) == {"y", "z"} and "unmeasured" in doc["skipped_axes"]["x"]
    code, _, err = _run(capsys, b, "--topic", "/imu", "--axes", "x", "y", "--out", tmp_path / "o2")
    assert code == 2 and "--axes x" in err and "unmeasured" in err


def test_axes_option_limits_the_analysis(bag, tmp_path, capsys):
    code, _, err = _run(capsys, bag, "--topic", "/imu", "--axes", "z", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert list(doc["axes"]) == ["z"] and set(doc["skipped_axes"]) == {"x", "y"}


def test_non_finite_samples_are_counted_dropped_and_refused_over_one_percent(tmp_path, capsys):
    g = _gyro()
    g[np.arange(100, N_MSG, 400), 1] = np.nan  # 15 of 6000: 0.25 %
    b = write_imu_bag(tmp_path / "few", _stamps(), g)
    code, _, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert doc["nonfinite_dropped"] == 15 and doc["sampling"]["segments"] == 16  # dropped, never interpolated
    g[np.arange(0, N_MSG, 60), 2] = np.inf  # 100 more rows, some the same: 1.8 %
    bad = int((~np.isfinite(g).all(axis=1)).sum())
    b = write_imu_bag(tmp_path / "many", _stamps(), g)
    code, _, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o2")
    assert code == 2 and "not finite" in err and f"{bad} of 6000" in err and bad > 60


def test_gaps_are_split_or_refused_and_backward_stamps_refused(tmp_path, capsys):
    keep = np.r_[0:2000, 2300:N_MSG]  # 3 s missing
    b = write_imu_bag(tmp_path / "gap", _stamps()[keep], _gyro()[keep])
    code, _, err = _run(capsys, b, "--topic", "/imu", "--gaps", "refuse", "--out", tmp_path / "o")
    assert code == 2 and "--gaps" in err and "1 gap(s)" in err
    code, _, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0 and "segments" in err  # the warning says it split
    s = json.loads((tmp_path / "o" / "allan.json").read_text())["sampling"]
    assert s["segments"] == 2 and s["gaps"] == 1 and s["longest_gap_s"] == pytest.approx(3.01)
    header = _stamps()
    header[3000], header[3001] = header[3001], header[3000]  # logged in order, stamped out of order
    b = write_imu_bag(tmp_path / "back", _stamps(), _gyro(), header_ns=header)
    code, _, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o3")
    assert code == 2 and "backwards" in err


def test_sqlite3_bag_with_unstamped_messages_uses_the_log_times(tmp_path, capsys):
    b = tmp_path / "db3"
    write_imu_bag(b, _stamps(), _gyro(), storage="sqlite3", stamped=False)
    assert list(b.glob("*.db3"))
    code, _, err = _run(capsys, b, "--topic", "/imu", "--axes", "x", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert doc["stamps"] == "log" and doc["sample_rate_hz"] == pytest.approx(RATE_HZ)


def test_accelerometer_field_in_si_units(tmp_path, capsys):
    vrw = 5e-4  # m/s²/√Hz
    acc = vrw * math.sqrt(RATE_HZ) * np.random.default_rng(1).standard_normal((N_MSG, 3)) + [0.0, 0.0, -9.8]
    b = write_imu_bag(tmp_path / "acc", _stamps(), _gyro(), accel=acc)
    code, _, err = _run(capsys, b, "--topic", "/imu", "--field", "linear_acceleration", "--out", tmp_path / "o",
                        "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert doc["field"] == "linear_acceleration" and doc["units"]["vrw_m_s2_rt_hz"] == "m/s²/√Hz"
    for axis in doc["axes"].values():
        assert axis["vrw_m_s2_rt_hz"] == pytest.approx(vrw, rel=0.1) and "vrw_sigma" in axis
        assert "bias_instability_m_s2" in axis and "accel_rw_m_s3_rt_hz" in axis
    import yaml
    params = yaml.safe_load((tmp_path / "o" / "sensor_models.yaml").read_text())["sensor_models"]["ros__parameters"]
    mean = np.mean([a["vrw_m_s2_rt_hz"] for a in doc["axes"].values()])
    assert params == {"platform_accel_noise_ug_rt_hz": pytest.approx(mean / 9.80665e-6)}
    assert "no filter" in (tmp_path / "o" / "filters.yaml").read_text()


@pytest.mark.parametrize("rate_hz", [100.0, 1000.0])
def test_a_three_second_bag_is_refused_naming_the_minimum_length(tmp_path, capsys, rate_hz):
    n = int(3.0 * rate_hz)
    stamps = EPOCH_NS + np.arange(n, dtype=np.int64) * int(1e9 / rate_hz)
    b = write_imu_bag(tmp_path / "short", stamps, _gyro(n))
    code, out, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    # ten octave tau values (2^9 samples) and ten times the longest of them: 5120 samples
    assert code == 2 and f"minimum length is {5120 / rate_hz:g} s" in err and "lasts 3 s" in err, err
    assert "Traceback" not in err and not (tmp_path / "o").exists()


def test_a_dead_axis_is_not_detected_and_not_averaged_as_zero(tmp_path, capsys):
    g = _gyro()
    g[:, 1] = 7e-5  # stuck: the output never changes
    b = write_imu_bag(tmp_path / "dead", _stamps(), g)
    code, out, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    dead = doc["axes"]["y"]
    assert dead["dead"] and dead["detected"] == [] and dead["arw_deg_rt_h"] is None
    assert "arw_deg_rt_h" in dead["not_detected"] and "y: dead" in out
    live = [doc["axes"][a]["arw_deg_rt_h"] for a in ("x", "z")]
    assert all(v == pytest.approx(ARW * 60 * 180 / math.pi, rel=0.1) for v in live)
    # the simulator gets the mean of the axes that detected the term, not a 0 for the dead one
    text = (tmp_path / "o" / "sensor_models.yaml").read_text()
    assert f"gimbal_gyro_arw_deg_rt_h: {float(np.mean(live))!r}"[:40] in text, text
    assert "axis y: dead" in text


def test_a_flagged_value_is_said_and_left_out_of_the_parameter_files(tmp_path, capsys):
    """A Gauss-Markov term whose correlation time (1 s) sits at the end of a 60 s record's τ
    range is fitted but not determined: flagged in the JSON, said on stderr, marked in the
    files' headers, and not put into the simulator's or the filters' values."""
    from scipy.signal import lfilter

    dt, tc, sigma = 1.0 / RATE_HZ, 1.0, 1e-2
    rng = np.random.default_rng(1)
    phi = math.exp(-dt / tc)
    z = sigma * math.sqrt(1 - phi * phi) * rng.standard_normal(N_MSG)
    z[0] = sigma * rng.standard_normal()
    g = _gyro(seed=3)
    g[:, 0] = ARW / math.sqrt(dt) * rng.standard_normal(N_MSG) + lfilter([1.0], [1.0, -phi], z)
    b = write_imu_bag(tmp_path / "flag", _stamps(), g)
    code, out, err = _run(capsys, b, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    x = doc["axes"]["x"]
    assert "bias_instability_deg_h" in x["detected"] and "bias_instability_deg_h" in x["flagged"], x["flagged"]
    assert x["bias_instability_deg_h"] > 0.0  # the JSON keeps the fitted value, flagged
    assert "warning: axis x: bias_instability_deg_h flagged" in err and "left out of sensor_models.yaml" in err
    assert not any("bias_instability_deg_h" in doc["axes"][a]["detected"] for a in ("y", "z"))
    text = (tmp_path / "o" / "sensor_models.yaml").read_text()
    assert "FLAGGED bias_instability_deg_h" in text and "left out of the values below" in text
    assert "gimbal_gyro_bi_deg_h: 0.0\n" in text, text


def test_every_undetected_term_has_a_finite_bound(bag, tmp_path, capsys):
    """White noise only: every other term, the Gauss-Markov one included, is reported not
    detected with a finite, positive bound (the largest over the correlation times the fit
    could have identified)."""
    code, _, err = _run(capsys, bag, "--topic", "/imu", "--out", tmp_path / "o", "--no-progress")
    assert code == 0, err
    for axis in json.loads((tmp_path / "o" / "allan.json").read_text())["axes"].values():
        assert "bias_instability_deg_h" in axis["not_detected"]
        assert all(v is not None and math.isfinite(v) and v > 0.0 for v in axis["not_detected"].values()), axis
