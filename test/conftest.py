"""Suite-wide ROS hygiene: DDS stays on loopback, and every process gets its own domain.

This runs before any test module imports rclpy, so the pytest process itself is covered;
tests that start node processes take a fresh id from the ``ros_domain_env`` fixture.
"""
from __future__ import annotations

import configparser
import os
import sys
from pathlib import Path

import pytest

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)

from gimbal_kinematics.ros.ros_domain import claim_domain_id  # noqa: E402

_SESSION_DOMAIN = claim_domain_id()
os.environ["ROS_DOMAIN_ID"] = str(_SESSION_DOMAIN.domain_id)

REPO_ROOT = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent


def console_scripts(pkg: str) -> list[tuple[str, str]]:
    """(executable, ``module:function``) of every ``console_scripts`` entry that
    ``src/<pkg>/setup.cfg`` declares (what colcon and pip turn into executables)."""
    cfg = configparser.ConfigParser()
    cfg.read(REPO_ROOT / "src" / pkg / "setup.cfg")
    specs = [line for line in cfg.get("options.entry_points", "console_scripts", fallback="").splitlines()
             if line.strip()]
    assert specs, f"{pkg}/setup.cfg declares no console_scripts"
    return [tuple(s.strip() for s in spec.partition("=")[::2]) for spec in specs]


def _claimed_env():
    claim = claim_domain_id()
    env = dict(os.environ)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(claim.domain_id)
    return env, claim


@pytest.fixture
def ros_domain_env() -> dict[str, str]:
    """Environment for a child process: loopback discovery and a domain id of its own."""
    env, claim = _claimed_env()
    yield env
    claim.release()


@pytest.fixture(scope="module")
def module_ros_domain_env() -> dict[str, str]:
    """Like ``ros_domain_env``, shared by the tests of one module (e.g. one recorded run)."""
    env, claim = _claimed_env()
    yield env
    claim.release()
