"""Write each node's ``config/<node>.yaml`` from its parameter table (a maintainer tool).

The nodes and their tables come from :data:`.registry.NODE_TYPES`. The tests fail when a
config file and its node's declared defaults disagree; regenerate with
``python -m gimbal_sim.graph.config_files``.
"""
from __future__ import annotations

from pathlib import Path

import gimbal_control
import gimbal_estimators
import gimbal_sim
from gimbal_kinematics.params import params_yaml

from .registry import NODE_TYPES

#: package name -> the package, whose source tree holds ``config/``.
_PACKAGES = {package.__name__: package for package in (gimbal_sim, gimbal_control, gimbal_estimators)}


def config_path(package: str, node_name: str) -> Path:
    """The source-tree config file (``src/<package>/config/<node>.yaml``)."""
    return Path(_PACKAGES[package].__file__).resolve().parents[1] / "config" / f"{node_name}.yaml"


def expected_text(node_name: str) -> str:
    return params_yaml(node_name, NODE_TYPES[node_name].params)


def main() -> None:
    for node_name, node_type in NODE_TYPES.items():
        path = config_path(node_type.package, node_name)
        path.write_text(expected_text(node_name))
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
