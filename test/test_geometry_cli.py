"""`gimbal-geometry` prints figures that agree with independent closed forms."""
import math
import re
import subprocess

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
