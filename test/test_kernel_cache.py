"""numba's cache directory is keyed by every kernel source: a change to any kernel (also one
that another module's kernel calls) gives a fresh directory, other files leave it alone; and
importing any package points numba (its own config, read in a fresh process) there."""
import os
import subprocess
import sys

from gimbal_kinematics.maths.kernel_cache import cache_dir, kernel_sources


def _tree(root, layout_source: bool):
    files = {}
    for pkg, kernel in (("gimbal_kinematics", "earth_kernels.py"), ("gimbal_control", "servo_kernels.py"),
                        ("gimbal_sim", "core/sighting_kernels.py")):
        base = root / pkg / pkg if layout_source else root / pkg
        (base / kernel).parent.mkdir(parents=True, exist_ok=True)
        (base / kernel).write_text(f"# {kernel}\n")
        (base / "other.py").write_text("x = 1\n")
        files[pkg] = base
    return files, files["gimbal_kinematics"] / "kernel_cache.py"


def test_any_kernel_change_moves_the_cache_and_nothing_else_does(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    for layout_source in (True, False):
        files, here = _tree(tmp_path / str(layout_source), layout_source)
        assert len(kernel_sources(here)) == 3
        first = cache_dir(here)
        assert first.parent == tmp_path / "cache" / "gimbal-numba"
        (files["gimbal_sim"] / "other.py").write_text("x = 2\n")
        assert cache_dir(here) == first
        (files["gimbal_control"] / "servo_kernels.py").write_text("# changed\n")
        assert cache_dir(here) != first


def test_importing_a_package_points_numba_at_the_keyed_directory(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = ("import gimbal_control, numba\nfrom gimbal_kinematics.maths.kernel_cache import cache_dir\n"
            "print(numba.config.CACHE_DIR == str(cache_dir()), str(cache_dir()).startswith(%r))" % str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["True", "True"], out.stderr
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    code = "import gimbal_sim, numba\nprint(numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == str(tmp_path / "mine"), out.stderr
