"""The four packages form a real ROS 2 (ament_python) workspace.

colcon (not our code) builds src/ into a temporary prefix; each executable declared in a
setup.cfg must then resolve the way ``ros2 run`` resolves it (ament index prefix +
``lib/<pkg>/<exe>``) and answer ``--help`` with exit code 0.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from conftest import REPO_ROOT, VENV_BIN, console_scripts
from ros_harness import interrupt_when_on_graph

PACKAGES = ("gimbal_kinematics", "gimbal_sim", "gimbal_control", "gimbal_estimators")
SRC = REPO_ROOT / "src"

#: Python import -> rosdep key that package.xml must declare for it.
ROSDEP_KEYS = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml",
               "matplotlib": "python3-matplotlib", "mcap": "python3-mcap", "mcap_ros2": "python3-mcap-ros2",
               "tqdm": "python3-tqdm", "allantools": "python3-allantools",
               "rosbags": "python3-rosbags", "distributed": "python3-distributed", "pyarrow": "python3-pyarrow",
               "pymavlink": "python3-pymavlink", "numba": "python3-numba",
               "zstandard": "python3-zstandard"}
ROS_PACKAGES = {"rclpy", "builtin_interfaces", "std_msgs", "sensor_msgs", "geometry_msgs", "nav_msgs",
                "rosgraph_msgs", "diagnostic_msgs", "rcl_interfaces", "ament_index_python", "rosidl_runtime_py"}


def declared_console_scripts(pkg: str) -> list[str]:
    """Executable names of the ``console_scripts`` in ``src/<pkg>/setup.cfg``."""
    return [exe for exe, _ in console_scripts(pkg)]


def imported_top_level_modules(pkg: str) -> set[str]:
    names: set[str] = set()
    for path in (SRC / pkg / pkg).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return names


@pytest.fixture(scope="module")
def colcon_install(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("colcon")
    result = subprocess.run(
        [str(VENV_BIN / "colcon"), "--log-base", str(base / "log"), "build", "--base-paths", str(SRC),
         "--build-base", str(base / "build"), "--install-base", str(base / "install")],
        cwd=base, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "4 packages finished" in result.stdout, result.stdout
    return base / "install"


def _sourced_env(install: Path) -> dict[str, str]:
    """What ``source install/setup.bash`` gives a shell, for our four packages."""
    env = dict(os.environ)
    prefixes = [str(install / pkg) for pkg in PACKAGES]
    site = [str(install / pkg / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages")
            for pkg in PACKAGES]
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(prefixes)
    env["PYTHONPATH"] = os.pathsep.join(site)
    return env


def test_package_manifests_are_ament_python_format_3():
    for pkg in PACKAGES:
        root = ET.parse(SRC / pkg / "package.xml").getroot()
        assert root.get("format") == "3"
        assert root.findtext("name") == pkg
        assert root.find("export/build_type").text == "ament_python"
        assert (SRC / pkg / "resource" / pkg).is_file()
        cfg = (SRC / pkg / "setup.cfg").read_text()
        assert f"description = {root.findtext('description')}\n" in cfg, f"{pkg}: setup.cfg and package.xml differ"
        assert f"install_scripts=$base/lib/{pkg}" in cfg and f"script_dir=$base/lib/{pkg}" in cfg


def test_package_xml_declares_exactly_the_dependencies_the_code_imports():
    for pkg in PACKAGES:
        root = ET.parse(SRC / pkg / "package.xml").getroot()
        listed = [e.text for tag in ("depend", "exec_depend") for e in root.findall(tag)]
        assert len(listed) == len(set(listed)), f"{pkg}: package.xml lists a dependency twice: {sorted(listed)}"
        declared = set(listed)
        used = set()
        for module in imported_top_level_modules(pkg):
            if module in ROSDEP_KEYS:
                used.add(ROSDEP_KEYS[module])
            elif module in ROS_PACKAGES or (module in PACKAGES and module != pkg):
                used.add(module)
        assert declared == used, f"{pkg}: package.xml declares {sorted(declared)}, code imports {sorted(used)}"


def test_colcon_build_installs_the_ament_index_and_config(colcon_install):
    for pkg in PACKAGES:
        assert (colcon_install / pkg / "share/ament_index/resource_index/packages" / pkg).is_file()
        assert (colcon_install / pkg / "share" / pkg / "package.xml").is_file()
        for cfg in (SRC / pkg / "config").glob("*.yaml"):
            assert (colcon_install / pkg / "share" / pkg / "config" / cfg.name).is_file()
        for urdf in (SRC / pkg / "urdf").glob("*.urdf"):
            assert (colcon_install / pkg / "share" / pkg / "urdf" / urdf.name).is_file()


def test_every_declared_executable_resolves_like_ros2_run_and_answers_help(colcon_install):
    from ament_index_python.packages import get_package_prefix

    env = _sourced_env(colcon_install)
    declared = {pkg: declared_console_scripts(pkg) for pkg in PACKAGES}
    assert "gimbal-run" in declared["gimbal_sim"]
    old = os.environ.get("AMENT_PREFIX_PATH")
    os.environ["AMENT_PREFIX_PATH"] = env["AMENT_PREFIX_PATH"]
    try:
        paths = {(pkg, exe): Path(get_package_prefix(pkg)) / "lib" / pkg / exe
                 for pkg, executables in declared.items() for exe in executables}
    finally:
        if old is None:
            os.environ.pop("AMENT_PREFIX_PATH", None)
        else:
            os.environ["AMENT_PREFIX_PATH"] = old
    for (pkg, exe), path in paths.items():
        assert path.is_file() and os.access(path, os.X_OK), f"ros2 run {pkg} {exe}: {path} missing"

    def answer(path: Path) -> subprocess.CompletedProcess:
        return subprocess.run([str(path), "--help"], env=env, capture_output=True, text=True, timeout=120)

    # each --help is a Python start-up, mostly waiting on imports: a few at once halve the wall time
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = dict(zip(paths, pool.map(answer, paths.values())))
    for (pkg, exe), result in results.items():
        assert result.returncode == 0, f"{pkg}/{exe} --help: {result.stderr}"
        assert "usage:" in result.stdout.lower(), f"{pkg}/{exe} --help printed no usage"


def test_venv_has_every_executable_on_path():
    for pkg in PACKAGES:
        for exe in declared_console_scripts(pkg):
            assert (VENV_BIN / exe).exists(), f"{exe} is not on the venv PATH; run `make venv`"


def test_packages_up_to_gimbal_estimators_build_alone_and_the_ekf_node_starts(tmp_path, ros_domain_env):
    """A hardware user builds only what the EKF needs: colcon's own dependency resolution from
    the manifests picks gimbal_kinematics and gimbal_estimators, nothing else, and the node
    starts from that install with gimbal_sim and gimbal_control made unimportable."""
    result = subprocess.run(
        [str(VENV_BIN / "colcon"), "--log-base", str(tmp_path / "log"), "build", "--base-paths", str(SRC),
         "--packages-up-to", "gimbal_estimators", "--build-base", str(tmp_path / "build"),
         "--install-base", str(tmp_path / "install")],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "2 packages finished" in result.stdout, result.stdout
    built = sorted(p.name for p in (tmp_path / "install").iterdir() if (p / "share" / p.name / "package.xml").is_file())
    assert built == ["gimbal_estimators", "gimbal_kinematics"]
    # Modules shadowing the packages above (first on sys.path): importing either fails loudly.
    blockers = tmp_path / "blockers"
    blockers.mkdir()
    for above in ("gimbal_sim", "gimbal_control"):
        (blockers / f"{above}.py").write_text(f"raise ImportError('{above} is not part of this install')\n")
    pyver = f"python{sys.version_info.major}.{sys.version_info.minor}"
    env = dict(ros_domain_env)
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(str(tmp_path / "install" / p) for p in built)
    env["PYTHONPATH"] = os.pathsep.join([str(blockers)] + [
        str(tmp_path / "install" / p / "lib" / pyver / "site-packages") for p in built])
    exe = tmp_path / "install" / "gimbal_estimators" / "lib" / "gimbal_estimators" / "gyro_bias_ekf"
    params = tmp_path / "install" / "gimbal_estimators" / "share" / "gimbal_estimators" / "config" / "gyro_bias_ekf.yaml"
    code, text = interrupt_when_on_graph([str(exe), "--ros-args", "--params-file", str(params)], env,
                                         "gyro_bias_ekf", tmp_path)
    assert code == 130, text  # Ctrl-C: interrupted, as every command (docs/usage.md)
    assert "Traceback" not in text, text


def test_colcon_resolves_gimbal_control_without_gimbal_estimators():
    """colcon's own dependency resolution from the manifests: a hardware user who builds only
    the controllers gets gimbal_kinematics with them and no estimator (the two are siblings)."""
    result = subprocess.run(
        [str(VENV_BIN / "colcon"), "--log-base", os.devnull, "list", "--base-paths", str(SRC),
         "--packages-up-to", "gimbal_control", "--names-only"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert sorted(result.stdout.split()) == ["gimbal_control", "gimbal_kinematics"], result.stdout
