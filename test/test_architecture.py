"""The package stack reads bottom-up, and the tests here keep it that way.

gimbal_kinematics (pure maths and rigid-body models; its ROS edge isolated in
``gimbal_kinematics.ros``) <- gimbal_estimators <- gimbal_control <- gimbal_sim (the
composition root). A module may import its own package and the packages below it, never one
above; cores never import rclpy or message packages; nothing reaches another package through
importlib. The import facts come from Python's own ``ast`` (every import statement, at any
depth, including function-local ones) and from a fresh interpreter's ``sys.modules``.
"""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO_ROOT

SRC = REPO_ROOT / "src"
#: Each package's level: a module may import packages of its level or below, never above.
LEVEL = {"gimbal_kinematics": 0, "gimbal_estimators": 1, "gimbal_control": 2, "gimbal_sim": 3}
#: Top-level modules of ROS 2 itself (rclpy and the message/interface packages).
ROS_MODULES = {"rclpy", "rcl_interfaces", "builtin_interfaces", "std_msgs", "sensor_msgs", "geometry_msgs",
               "rosgraph_msgs", "diagnostic_msgs", "ament_index_python", "rosidl_runtime_py", "rpyutils"}
#: The one module allowed to use importlib: the bag tools' message-type registry, which must
#: resolve message types named in a foreign bag at run time.
IMPORTLIB_REGISTRY = SRC / "gimbal_sim" / "gimbal_sim" / "bag" / "schemas.py"
MAX_LINES = 700


def modules(pkg: str) -> list[Path]:
    return sorted(p for p in (SRC / pkg / pkg).rglob("*.py"))


def imports_of(path: Path) -> set[str]:
    """Top-level names of every absolute import in ``path`` (relative imports stay inside)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def is_ros_edge(pkg: str, path: Path) -> bool:
    """Modules allowed to import rclpy: nodes, each package's message conversion, the shared
    ROS edge, and gimbal_sim's graph tooling (orchestrator, bags, bench, reports' decoders)."""
    rel = path.relative_to(SRC / pkg / pkg)
    if pkg == "gimbal_kinematics":
        return rel.parts[0] == "ros"
    if path.name.endswith("_node.py") or path.name == "messages.py":
        return True
    if pkg == "gimbal_sim":
        core_parts = {"plant", "sensors", "experiments"}
        core_files = {"vehicle.py", "sensor_suite.py", "core_loop.py", "core_stages.py", "core_ideal.py"}
        return not (rel.parts[0] in core_parts or (len(rel.parts) == 1 and rel.name in core_files))
    return False


@pytest.mark.parametrize("pkg", list(LEVEL))
def test_no_package_imports_a_package_above_it(pkg):
    bad = []
    for path in modules(pkg):
        for name in imports_of(path) & set(LEVEL):
            if LEVEL[name] > LEVEL[pkg]:
                bad.append(f"{path.relative_to(SRC)} imports {name}")
    assert not bad, "upward imports:\n" + "\n".join(bad)


@pytest.mark.parametrize("pkg", list(LEVEL))
def test_core_modules_do_not_import_rclpy_or_messages(pkg):
    bad = [f"{path.relative_to(SRC)} imports {sorted(imports_of(path) & ROS_MODULES)}"
           for path in modules(pkg) if not is_ros_edge(pkg, path) and imports_of(path) & ROS_MODULES]
    assert not bad, "core modules with ROS imports:\n" + "\n".join(bad)


def test_importing_gimbal_kinematics_loads_no_ros():
    """Importing every pure module of gimbal_kinematics (transitively) leaves rclpy and every
    message package out of ``sys.modules``: a hardware user's core needs no ROS."""
    pure = [".".join(p.relative_to(SRC / "gimbal_kinematics").with_suffix("").parts).removesuffix(".__init__")
            for p in modules("gimbal_kinematics") if "ros" not in p.relative_to(SRC / "gimbal_kinematics").parts]
    code = ("import sys\n" + "".join(f"import {m}\n" for m in pure) +
            "print(sorted({n.split('.')[0] for n in sys.modules} & set(sys.argv[1:])))")
    out = subprocess.run([sys.executable, "-c", code, *sorted(ROS_MODULES)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"pure gimbal_kinematics modules loaded {out.stdout.strip()}"
    assert len(pure) > 10


def test_importlib_only_in_the_one_registry():
    bad = []
    for pkg in LEVEL:
        for path in modules(pkg):
            uses = "importlib" in imports_of(path) or "__import__(" in path.read_text()
            if uses and path != IMPORTLIB_REGISTRY:
                bad.append(str(path.relative_to(SRC)))
    assert not bad, f"importlib outside {IMPORTLIB_REGISTRY.relative_to(SRC)}: {bad}"


def test_no_module_is_over_700_lines():
    long = {str(p.relative_to(SRC)): n for pkg in LEVEL for p in modules(pkg)
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def test_every_package_manifest_lists_only_packages_below_it():
    import xml.etree.ElementTree as ET

    for pkg in LEVEL:
        root = ET.parse(SRC / pkg / "package.xml").getroot()
        deps = {e.text for tag in ("depend", "exec_depend") for e in root.findall(tag)}
        above = [d for d in deps & set(LEVEL) if LEVEL[d] > LEVEL[pkg]]
        assert not above, f"{pkg}/package.xml depends on {above}, above it"


def node_entry_points() -> dict[str, tuple[str, str]]:
    """executable -> (package, module) of every ``<module>_node:main`` console script that the
    packages' ``setup.py`` declare (the graph's nodes; CLIs like gimbal-run are not nodes)."""
    out = {}
    for pkg in LEVEL:
        for node in ast.walk(ast.parse((SRC / pkg / "setup.py").read_text())):
            if isinstance(node, ast.keyword) and node.arg == "entry_points":
                for spec in ast.literal_eval(node.value).get("console_scripts", []):
                    exe, _, target = (s.strip() for s in spec.partition("="))
                    module = target.partition(":")[0]
                    if module.endswith("_node"):
                        out[exe] = (pkg, module)
    return out


def test_every_node_parameter_table_loads_without_ros():
    """Each node's ``<node>_params`` module (its PARAMS and DESCRIPTION, what scenario checks,
    the config generator and the core loop read) and the node registry import in a fresh
    interpreter without rclpy or any message package."""
    modules = [module.removesuffix("_node") + "_params" for _, module in node_entry_points().values()]
    code = ("import sys\n" + "".join(f"import {m}\n" for m in modules) + "import gimbal_sim.registry\n" +
            "for m in sys.argv[1:]:\n    assert sys.modules[m].PARAMS and sys.modules[m].DESCRIPTION, m\n" +
            "print(sorted({n.split('.')[0] for n in sys.modules} & set(%r)))" % sorted(ROS_MODULES))
    out = subprocess.run([sys.executable, "-c", code, *modules], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"parameter tables loaded {out.stdout.strip()}"
    assert len(modules) == 10


def test_the_registry_lists_every_node_executable_with_its_package_table_and_class():
    from gimbal_sim.registry import NODE_TYPES

    nodes = node_entry_points()
    assert len(nodes) == 10 and set(NODE_TYPES) == set(nodes)
    for exe, (pkg, module) in nodes.items():
        node_type = NODE_TYPES[exe]
        table = sys.modules.get(module.removesuffix("_node") + "_params")
        assert node_type.package == pkg and table is not None, exe
        assert node_type.params is table.PARAMS and node_type.description is table.DESCRIPTION, exe
        assert node_type.node_class().__module__ == module, exe
