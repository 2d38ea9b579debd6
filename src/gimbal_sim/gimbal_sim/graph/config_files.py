"""Write each node's ``config/<node>.yaml`` and the parameter reference ``docs/parameters.md``
from the nodes' parameter declarations (a maintainer tool).

The nodes and their tables come from :data:`.registry.NODE_TYPES`. The tests fail when a
config file or the reference and the node's declared parameters disagree; regenerate with
``python -m gimbal_sim.graph.config_files``.
"""
from __future__ import annotations

from pathlib import Path

import gimbal_control
import gimbal_estimators
import gimbal_sim
from gimbal_kinematics.params.table import params_markdown, params_yaml

from .registry import NODE_TYPES

#: package name -> the package, whose source tree holds ``config/``.
_PACKAGES = {package.__name__: package for package in (gimbal_sim, gimbal_control, gimbal_estimators)}


def config_path(package: str, node_name: str) -> Path:
    """The source-tree config file (``src/<package>/config/<node>.yaml``)."""
    return Path(_PACKAGES[package].__file__).resolve().parents[1] / "config" / f"{node_name}.yaml"


def expected_text(node_name: str) -> str:
    return params_yaml(node_name, NODE_TYPES[node_name].params)


#: The parameter reference, in the source tree's ``docs/``.
DOCS_PATH = Path(gimbal_sim.__file__).resolve().parents[3] / "docs" / "parameters.md"


def parameters_doc() -> str:
    """``docs/parameters.md``: every node's parameters, one table a node."""
    head = ["# Node parameters", "",
            "Every parameter of every node: its type, default, unit, range or choices and what it does. "
            "This page, each node's `config/<node>.yaml` and the table the node declares are generated from one "
            "declaration a node (a dataclass of `param` fields in its `<node>_params.py`, "
            "[interfaces](interfaces.md#parameters)); `python -m gimbal_sim.graph.config_files` rewrites them "
            "and a test fails when they disagree. A number is in the unit shown; a range is inclusive.", ""]
    sections = [params_markdown(name, t.package, t.description, t.params) for name, t in NODE_TYPES.items()]
    return "\n".join(head) + "\n" + "\n".join(sections)


def main() -> None:
    for node_name, node_type in NODE_TYPES.items():
        path = config_path(node_type.package, node_name)
        path.write_text(expected_text(node_name))
        print(f"wrote {path}")
    DOCS_PATH.write_text(parameters_doc())
    print(f"wrote {DOCS_PATH}")


if __name__ == "__main__":
    main()
