"""`gimbal-geometry` prints figures that agree with independent closed forms."""
import math
import re
import subprocess

import numpy as np
import pymap3d as pm
import pytest
from scipy.spatial.transform import Rotation

from conftest import VENV_BIN

EXE = str(VENV_BIN / "gimbal-geometry")


def _run(*args):
    return subprocess.run([EXE, *args], capture_output=True, text=True, timeout=60)


def _floats(text):
    return [float(x) for x in re.findall(r"-?\d+\.\d+", text)]


def test_los_matches_scipy():
    euler, joints = (2.0, -3.0, 40.0), (10.0, 25.0, 7.5)
    out = _run("los", "--euler-deg", *map(str, euler), "--joints-deg", *map(str, joints))
    assert out.returncode == 0, out.stderr
    az, el = _floats(out.stdout)
    C_nm = (Rotation.from_euler("ZYX", euler[::-1], degrees=True)
            * Rotation.from_euler("z", joints[0] + joints[1], degrees=True)
            * Rotation.from_euler("y", joints[2], degrees=True))
    los = C_nm.apply([1.0, 0.0, 0.0])
    assert math.isclose(az, math.degrees(math.atan2(los[1], los[0])), abs_tol=2e-6)
    assert math.isclose(el, math.degrees(math.asin(-los[2])), abs_tol=2e-6)


def test_fdop_is_root_two_over_sine_of_the_crossing_angle():
    out = _run("fdop", "--lat-deg", "35", "--lon-deg", "120", "--gyro-a", "1", "0", "0",
               "--gyro-b", "0", "1", "0.5", "--sigma-arcsec", "10")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    alpha_a, alpha_b = _floats(lines[0])[1], _floats(lines[1])[1]
    fdop = _floats(lines[2])[0]
    assert math.isclose(fdop, math.sqrt(2) / abs(math.sin(math.radians(alpha_b - alpha_a))), rel_tol=1e-3)
    error_m = _floats(lines[3])[0]
    # drms on a ~6371 km sphere, to the curvature difference (< 1 %)
    assert math.isclose(error_m, fdop * math.radians(10 / 3600) * 6.371e6, rel_tol=1e-2)


def test_bad_input_exits_2_with_the_cause():
    out = _run("fdop", "--lat-deg", "35", "--lon-deg", "0", "--gyro-a", "0", "0", "0", "--gyro-b", "0", "1", "0")
    assert out.returncode == 2 and "--gyro-a" in out.stderr
    out = _run("los", "--euler-deg", "0", "0", "0")
    assert out.returncode == 2 and "--joints-deg" in out.stderr


def _point(*args):
    return _run("point", "--vehicle", "39.9", "32.8", "900", "--euler-deg", "1.5", "-1", "60", *args)


def _budget_terms(stdout):
    lines = stdout.splitlines()
    start = lines.index("pointing error budget, 1-sigma:") + 1
    return {line.strip().rsplit(" ", 2)[0]: float(line.split()[-2]) for line in lines[start:-1]}


def test_point_agrees_with_pymap3d_and_the_forward_chain():
    target = (39.92, 32.83, 750.0)
    out = _point("--target", *map(str, target), "--turret-deg", "5")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    rng_m, (az, el), (psi_t, psi_m, theta_m) = _floats(lines[0])[0], _floats(lines[1]), _floats(lines[2])
    az_ref, el_ref, range_ref = pm.geodetic2aer(*target, 39.9, 32.8, 900.0)
    assert math.isclose(rng_m, range_ref, abs_tol=1e-3)
    assert math.isclose(az, az_ref, abs_tol=2e-6) and math.isclose(el, el_ref, abs_tol=2e-6)
    assert "limits azimuth no  elevation no  turret handover no  singular no" in lines[3]
    assert psi_t == 5.0
    los = (Rotation.from_euler("ZYX", [60.0, -1.0, 1.5], degrees=True)
           * Rotation.from_euler("z", psi_t + psi_m, degrees=True)
           * Rotation.from_euler("y", theta_m, degrees=True)).apply([1.0, 0.0, 0.0])
    ned = np.array(pm.geodetic2ned(*target, 39.9, 32.8, 900.0))
    # six printed decimals of a degree: ~2e-8 rad per angle
    assert math.acos(min(1.0, float(los @ ned) / float(np.linalg.norm(ned)))) < 1e-7


def test_point_budget_closed_form_for_a_level_vehicle_looking_north():
    target = pm.ned2geodetic(2000.0, 0.0, 0.0, 10.0, 20.0, 0.0)
    out = _run("point", "--vehicle", "10", "20", "0", "--euler-deg", "0", "0", "0",
               "--target", *(f"{v:.12f}" for v in target), "--sigma-attitude-deg", "0.05", "0.05", "0.2",
               "--sigma-vehicle-m", "3", "4", "--sigma-target-m", "5", "6")
    assert out.returncode == 0, out.stderr
    t = _budget_terms(out.stdout)
    mrad = math.radians(1.0) * 1e3
    assert t["roll"] == 0.0  # a roll error turns the sight about its own LOS
    assert math.isclose(t["pitch"], 0.05 * mrad, abs_tol=1e-4) and math.isclose(t["heading"], 0.2 * mrad, abs_tol=1e-4)
    for name, sigma in (("vehicle horizontal", 3.0), ("vehicle vertical", 4.0),
                        ("target horizontal", 5.0), ("target vertical", 6.0)):
        assert math.isclose(t[name], sigma / 2000.0 * 1e3, abs_tol=1e-4), name


def test_point_hands_the_azimuth_to_the_turret_at_the_gimbal_limit():
    out = _point("--target", "39.92", "32.8", "900", "--azimuth-limits-deg", "-30", "30", "--handover", "turret")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    psi_t, psi_m, _ = _floats(lines[2])
    assert psi_m == -30.0 and psi_t < -30.0
    assert "limits azimuth yes" in lines[3] and "turret handover yes" in lines[3]
    out = _point("--target", "39.92", "32.8", "900", "--azimuth-limits-deg", "-30", "30")
    assert "turret handover no" in out.stdout and _floats(out.stdout.splitlines()[3])[0] > 0.0  # residual


@pytest.mark.parametrize("args, cause", [
    (("--target", "39.9", "32.8", "900"), "minimum range"),
    (("--target", "95", "32.8", "900"), "latitude 95"),
    (("--target", "nan", "32.8", "900"), "must be finite"),
    (("--target", "39.92", "32.8", "900", "--turret-deg", "inf"), "--turret-deg must be finite"),
    (("--target", "39.92", "32.8", "900", "--sigma-vehicle-m", "-1", "0"),
     "--sigma-vehicle-m is a 1-sigma and must be >= 0"),
    (("--target", "39.92", "32.8"), "--target"),
])
def test_point_bad_input_exits_2_with_the_cause(args, cause):
    out = _point(*args)
    assert out.returncode == 2 and cause in out.stderr and "Traceback" not in out.stderr
