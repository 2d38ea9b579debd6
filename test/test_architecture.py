"""The package stack reads bottom-up, and the tests here keep it that way.

gimbal_kinematics (pure maths and rigid-body models; its ROS edge isolated in
``gimbal_kinematics.ros``) <- gimbal_estimators, gimbal_control
(siblings: neither imports the other) <- gimbal_sim (the
composition root). A module may import its own package and the packages below it, never one
above; inside gimbal_sim and gimbal_kinematics the same holds for their rooms (subpackages,
:data:`ROOM`, :data:`KINEMATICS_ROOM`); cores
never import rclpy or message packages; nothing reaches another package through importlib;
no two modules import each other, directly or round a loop; a function-local import is
kept only for a third-party library or a target named in :data:`LAZY_TARGETS`; modules and
functions stay short. The import facts come from Python's own ``ast`` (every import
statement, at any depth, including function-local ones) and from a fresh interpreter's
``sys.modules``.
"""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO_ROOT, console_scripts

SRC = REPO_ROOT / "src"
#: Each package's level: a module may import packages of its level or below, never above; the two
#: packages of level 1 are siblings and import neither each other (SIBLINGS).
LEVEL = {"gimbal_kinematics": 0, "gimbal_estimators": 1, "gimbal_control": 1, "gimbal_sim": 2}
#: Top-level modules of ROS 2 itself (rclpy and the message/interface packages).
ROS_MODULES = {"rclpy", "rcl_interfaces", "builtin_interfaces", "std_msgs", "sensor_msgs", "geometry_msgs",
               "rosgraph_msgs", "diagnostic_msgs", "ament_index_python", "rosidl_runtime_py", "rpyutils"}
#: The one module allowed to use importlib: the bag tools' message-type registry, which must
#: resolve message types named in a foreign bag at run time.
IMPORTLIB_REGISTRY = SRC / "gimbal_sim" / "gimbal_sim" / "bag" / "schemas.py"
MAX_LINES = 600
MAX_FUNCTION_LINES = 80
#: A function longer than MAX_FUNCTION_LINES says why in a comment line starting with this.
LONG_MARK = "# long:"
#: gimbal_sim's rooms, bottom-up: a module may import its own room and the rooms below it.
#: The no-ROS engine (core) sits below everything that runs ROS code for a run (reports'
#: decoders, the campaign's graph runs, the tools); the world models are the floor.
ROOM = {
    "__init__": 0,      # the package's docstring
    "figures": 0,       # the matplotlib set-up every plot shares (reports, allan, campaign)
    "page": 0,          # a report's index.html (runs, comparisons, campaigns)
    "world": 1,         # vehicle, plant, sensors, sensor suite: pure models
    "bag": 2,           # MCAP/rosbag2 reading, writing, comparing, playing
    "allan": 3,         # Allan-variance characterisation of a recorded IMU
    "nodes": 4,         # gimbal_sim's own rclpy nodes and their parameter tables
    "mavlink": 4,       # MAVLink Gimbal Protocol v2: device and manager cores, their nodes, the UDP link
    "graph": 5,         # node registry, scenarios, node plan, config files, orchestrator
    "core": 6,          # the no-ROS engine
    "campaign": 7,      # the campaign engine, its spec, results table, report, experiment types
    "reports": 8,       # a run's report from its bag (or a core run's series), gimbal-report
    "experiments": 9,   # the paper runners and their registry
    "tools": 10,        # gimbal-bench, replay speed, Allan speed and round trip
    "run_cli": 11,      # gimbal-run
    "campaign_cli": 11,  # gimbal-campaign
}
#: Top-level modules of gimbal_sim besides __init__.py: at most this many.
MAX_TOP_LEVEL = 4
#: Project modules a function may import lazily, each with why (the prefix matches the
#: module and everything under it; ``*_node`` matches every node module).
LAZY_TARGETS = {
    "*_node": "a node module loads rclpy; the registry hands out node classes only to run them, so "
              "scenario checks, config files and the core loop read the registry without ROS",
    "gimbal_kinematics.ros.node_main": "loads rclpy (the executor): only the command that starts nodes needs it",
    "gimbal_sim.bag.player": "loads rclpy: gimbal-bag's other commands run without ROS",
    "gimbal_sim.bag.live": "loads rclpy and the Foxglove SDK: only gimbal-bag play --live needs the live view",
    "gimbal_sim.bag.any_reader": "loads rosbags (slow to import): only a bag that is not ours needs it",
    "gimbal_kinematics.maths.rotation_kernels": "loads numba (about 70 MB and 0.2 s a process): rotations are used "
                                                "everywhere, by processes (recorder, bag tools) that run no kernel",
    "gimbal_kinematics.maths.earth_kernels": "loads numba, as rotation_kernels: the earth's functions are used everywhere",
}


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
        return rel.parts[0].removesuffix(".py") not in {"world", "core", "campaign", "experiments", "figures",
                                                         "__init__"}
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


def test_no_module_is_over_600_lines():
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
    packages' ``setup.cfg`` declare (the graph's nodes; CLIs like gimbal-run are not nodes)."""
    out = {}
    for pkg in LEVEL:
        for exe, target in console_scripts(pkg):
            module = target.partition(":")[0]
            if module.endswith("_node"):
                out[exe] = (pkg, module)
    return out


def test_every_node_parameter_table_loads_without_ros():
    """Each node's ``<node>_params`` module (its PARAMS and DESCRIPTION, what scenario checks,
    the config generator and the core loop read) and the node registry import in a fresh
    interpreter without rclpy or any message package."""
    modules = [module.removesuffix("_node") + "_params" for _, module in node_entry_points().values()]
    code = ("import sys\n" + "".join(f"import {m}\n" for m in modules) + "import gimbal_sim.graph.registry\n" +
            "for m in sys.argv[1:]:\n    assert sys.modules[m].PARAMS and sys.modules[m].DESCRIPTION, m\n" +
            "print(sorted({n.split('.')[0] for n in sys.modules} & set(%r)))" % sorted(ROS_MODULES))
    out = subprocess.run([sys.executable, "-c", code, *modules], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"parameter tables loaded {out.stdout.strip()}"
    assert len(modules) == 15


def test_the_registry_lists_every_node_executable_with_its_package_table_and_class():
    from gimbal_sim.graph.registry import NODE_TYPES

    nodes = node_entry_points()
    assert len(nodes) == 15 and set(NODE_TYPES) == set(nodes)
    for exe, (pkg, module) in nodes.items():
        node_type = NODE_TYPES[exe]
        table = sys.modules.get(module.removesuffix("_node") + "_params")
        assert node_type.package == pkg and table is not None, exe
        assert node_type.params is table.PARAMS and node_type.description is table.DESCRIPTION, exe
        assert node_type.node_class().__module__ == module, exe


def test_every_console_script_names_a_function_of_a_module_in_src():
    """Each ``console_scripts`` entry of the packages' ``setup.cfg`` (what colcon and pip turn
    into executables) names a module file under src/ that defines the function, read with
    ``ast`` without importing it: a module moved or renamed leaves no entry point behind."""
    missing, count = [], 0
    for pkg in LEVEL:
        for exe, target in console_scripts(pkg):
            module, _, func = target.partition(":")
            base = SRC / pkg / Path(*module.split("."))
            path = next((p for p in (base.with_suffix(".py"), base / "__init__.py") if p.is_file()), None)
            defined = path is not None and any(
                isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.name == func
                for n in ast.parse(path.read_text()).body)
            count += 1
            if not (module.split(".")[0] == pkg and defined):
                missing.append(f"{pkg}/setup.cfg: {exe} = {target}")
    assert not missing, "entry points naming no function of a module in src/:\n" + "\n".join(missing)
    assert count > 20


# ------------------------------------------------------------------ the import graph
def module_index(src: Path) -> dict[str, Path]:
    """Dotted name -> file of every module of the packages laid out as ``src/<pkg>/<pkg>/``."""
    mods = {}
    for init in src.glob("*/*/__init__.py"):
        root = init.parent
        for path in root.rglob("*.py"):
            rel = path.relative_to(root.parent).with_suffix("")
            mods[".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)] = path
    return mods


def imports_in(name: str, path: Path, mods: dict[str, Path]) -> list[tuple[str, bool]]:
    """(project module imported, whether the import is function-local) for every import
    statement of module ``name``; relative imports resolved, third-party ones left out. An
    ``from a import b`` names module ``a.b`` when there is one, else ``a``."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    local: set[int] = set()
    tree = ast.parse(path.read_text(), str(path))
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            local.update(id(n) for n in ast.walk(fn) if isinstance(n, (ast.Import, ast.ImportFrom)))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
        else:
            continue
        for target in targets:
            while target and target not in mods:
                target = target.rpartition(".")[0]
            # a module importing its own package's __init__ is how Python loads it anyway
            if target and target != name and not name.startswith(target + "."):
                out.append((target, id(node) in local))
    return out


def import_cycles(src: Path) -> list[list[str]]:
    """Every set of modules that import each other round a loop (strongly connected
    components of more than one module, Tarjan's algorithm), each sorted."""
    mods = module_index(src)
    edges = {m: {t for t, _ in imports_in(m, p, mods)} for m, p in mods.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in mods:
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_cycles_between_the_projects_modules():
    cycles = import_cycles(SRC)
    assert not cycles, "import cycles:\n" + "\n".join(", ".join(c) for c in cycles)
    assert len(module_index(SRC)) > 100


def _write_package(src: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        path = src / "planted" / "planted" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


@pytest.mark.parametrize("b_imports_a", [
    "from .a import A\n",                                                 # at the top
    "def f():\n    from .a import A\n    return A\n",                      # function-local
    "def f():\n    from planted import a\n    return a.A\n",               # absolute, module by name
])
def test_the_cycle_check_finds_a_planted_cycle(tmp_path, b_imports_a):
    """The checker above on a two-module package written here: a imports b at the top, b
    imports a (at the top or inside a function) -> one cycle {a, b}; a third module that
    only imports numpy and a stays out of it."""
    _write_package(tmp_path, {"__init__.py": "", "a.py": "from .b import f\nA = 1\n", "b.py": b_imports_a,
                              "c.py": "import numpy\nfrom . import a\n"})
    assert import_cycles(tmp_path) == [["planted.a", "planted.b"]]
    _write_package(tmp_path, {"b.py": "import numpy\n"})
    assert import_cycles(tmp_path) == []


def _lazy_allowed(target: str) -> bool:
    return any(target.endswith("_node") if key == "*_node" else target == key or target.startswith(key + ".")
               for key in LAZY_TARGETS)


def test_function_local_imports_only_of_third_party_or_the_allowed_targets():
    mods = module_index(SRC)
    bad = [f"{mods[m].relative_to(SRC)} imports {t} inside a function"
           for m in mods for t, local in imports_in(m, mods[m], mods) if local and not _lazy_allowed(t)]
    assert not bad, "function-local imports of project modules (make them top-level, or add the target to " \
                    "LAZY_TARGETS with its reason):\n" + "\n".join(bad)


def room_of(module: str) -> str:
    return module.split(".")[1] if "." in module else "__init__"


def test_gimbal_sim_rooms_import_only_their_own_room_or_rooms_below():
    mods = module_index(SRC)
    sim = {m: p for m, p in mods.items() if m.split(".")[0] == "gimbal_sim"}
    unknown = sorted({room_of(m) for m in sim} - set(ROOM))
    assert not unknown, f"gimbal_sim rooms without a level in ROOM: {unknown}"
    bad = [f"{m} ({room_of(m)}) imports {t} ({room_of(t)})"
           for m, p in sim.items() for t, _ in imports_in(m, p, mods)
           if t.split(".")[0] == "gimbal_sim" and ROOM[room_of(t)] > ROOM[room_of(m)]]
    assert not bad, "imports of a room above:\n" + "\n".join(bad)


@pytest.mark.parametrize("room", ["world", "core"])
def test_importing_the_pure_rooms_of_gimbal_sim_loads_no_ros(room):
    """Every module of gimbal_sim's ``world`` (the models) and ``core`` (the no-ROS engine),
    imported in a fresh interpreter, leaves rclpy and every message package out of
    ``sys.modules``."""
    names = sorted(m for m in module_index(SRC) if m.startswith(f"gimbal_sim.{room}"))
    code = ("import sys\n" + "".join(f"import {m}\n" for m in names) +
            "print(sorted({n.split('.')[0] for n in sys.modules} & set(sys.argv[1:])))")
    out = subprocess.run([sys.executable, "-c", code, *sorted(ROS_MODULES)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"gimbal_sim.{room} loaded {out.stdout.strip()}"
    assert len(names) > 2


def test_gimbal_sim_has_at_most_four_top_level_modules():
    top = sorted(p.name for p in (SRC / "gimbal_sim" / "gimbal_sim").glob("*.py") if p.name != "__init__.py")
    assert len(top) <= MAX_TOP_LEVEL, f"top-level modules of gimbal_sim (put them in a room): {top}"


def test_no_function_is_over_80_lines_unless_it_says_why():
    long = []
    for pkg in LEVEL:
        for path in modules(pkg):
            text = path.read_text()
            lines = text.splitlines()
            for node in ast.walk(ast.parse(text, str(path))):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    body = lines[node.lineno - 1:node.end_lineno]
                    if len(body) > MAX_FUNCTION_LINES and not any(b.strip().startswith(LONG_MARK) for b in body):
                        long.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({len(body)} lines)")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines without a '{LONG_MARK}' comment:\n" + "\n".join(long)


# ------------------------------------------------------------------ one engine
EXPERIMENTS = SRC / "gimbal_sim" / "gimbal_sim" / "experiments"


def _steps_in_loop(loop: ast.AST) -> bool:
    """A ``for``/``while`` loop that steps something itself: a ``*.step(...)`` call in its body
    (nested function definitions excluded: an engine stage is a function the engine calls), or
    a ``while`` on ``*.finished``."""
    if isinstance(loop, ast.While) and any(isinstance(n, ast.Attribute) and n.attr == "finished"
                                           for n in ast.walk(loop.test)):
        return True
    todo = list(loop.body) + list(loop.orelse)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "step":
            return True
        todo.extend(ast.iter_child_nodes(node))
    return False


def step_loops(path: Path) -> list[str]:
    """Where ``path`` steps in a loop of its own (:func:`_steps_in_loop`), or says ``for k in
    range`` (the step loop's usual form)."""
    text = path.read_text()
    found = [f"{path.name}:{i} 'for k in range'" for i, line in enumerate(text.splitlines(), 1)
             if "for k in range" in line]
    found += [f"{path.name}:{n.lineno} {type(n).__name__.lower()} loop stepping a core"
              for n in ast.walk(ast.parse(text, str(path))) if isinstance(n, (ast.For, ast.While)) and _steps_in_loop(n)]
    return found


def test_experiments_have_no_step_loop_of_their_own():
    """``core/`` is the only stepper outside the graph: an experiment declares (scenario,
    variants, options, table) or hands stages and an observer to ``core_loop.run_stages``."""
    bad = [f for path in sorted(EXPERIMENTS.glob("*.py")) for f in step_loops(path)]
    assert not bad, "experiments stepping in their own loop:\n" + "\n".join(bad)


def test_the_step_loop_rule_finds_planted_loops(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text("def a(core):\n    while not core.finished:\n        core.step(())\n\n"
                       "def b(truth, n):\n    for k in range(n):\n        pass\n\n"
                       "def c(items):\n    for x in items:\n        x.step(1.0)\n\n"
                       "def d(items):\n    for x in items:\n        def stage(bus):\n            bus.core.step(())\n")
    assert sorted(f.split()[0] for f in step_loops(planted)) == ["planted.py:10", "planted.py:2", "planted.py:6"]


#: What ``reports/`` may read from the graph room: the scenario files and the node tables
#: (metadata: what a run was, a parameter's default). Nothing that runs a node or the engine.
REPORTS_GRAPH_METADATA = {"gimbal_sim.graph.scenario", "gimbal_sim.graph.registry"}


def test_reports_run_nothing():
    """A report reads recordings: no module of ``reports/`` imports the engine (``core/``) or
    the graph's running parts (``graph/`` beyond :data:`REPORTS_GRAPH_METADATA`)."""
    index = module_index(SRC)
    bad = []
    for name, path in sorted(index.items()):
        if not name.startswith("gimbal_sim.reports"):
            continue
        for target in sorted({t for t, _ in imports_in(name, path, index)}):
            if target.startswith("gimbal_sim.core") or (target.startswith("gimbal_sim.graph")
                                                         and target not in REPORTS_GRAPH_METADATA):
                bad.append(f"{name} imports {target}")
    assert not bad, "reports importing a runner:\n" + "\n".join(bad)


# ------------------------------------------------------------------ one timing edge
#: gimbal_kinematics' timing room and its modules: stamps, order, pairing, duplicates, clock
#: jumps, staleness and step grouping (the nodes' input policies). Matched by name, in whichever
#: room a module sits.
TIMING_MODULES = {"timing", "input_policy", "control_policy", "sync", "stamps", "stream_stats"}
#: Cores that still judge stamps through a timing module, each with the piece that stays to
#: move into its node's input policy. The list only shrinks (the test says when to drop one).
STAMP_CHECKING_CORES: dict[str, str] = {}


def core_modules() -> list[Path]:
    """The estimator and controller cores: every module of gimbal_estimators and gimbal_control
    but the nodes and their ROS edge (parameter tables, message conversion, serialisation)."""
    return [p for pkg in ("gimbal_estimators", "gimbal_control") for p in modules(pkg)
            if not p.stem.endswith(("_node", "_params")) and p.stem not in {"messages", "wire", "__init__"}]


def timing_imports(path: Path) -> set[str]:
    """The timing modules (:data:`TIMING_MODULES`) of gimbal_kinematics that ``path`` imports."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("gimbal_kinematics"):
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names if alias.name.startswith("gimbal_kinematics")]
        else:
            continue
        found.update(part for name in names for part in name.split(".")[1:] if part in TIMING_MODULES)
    return found


def test_no_core_imports_a_timing_module():
    """A core gets checked samples in stamp order from its node's input policy: it imports
    nothing that judges stamps (but the cores still listed in :data:`STAMP_CHECKING_CORES`)."""
    importing = {p.stem: sorted(timing_imports(p)) for p in core_modules() if timing_imports(p)}
    bad = {stem: mods for stem, mods in importing.items() if stem not in STAMP_CHECKING_CORES}
    assert not bad, f"cores importing timing modules (stamp logic belongs to the input policy): {bad}"
    done = set(STAMP_CHECKING_CORES) - set(importing)
    assert not done, f"no longer import a timing module; drop them from STAMP_CHECKING_CORES: {sorted(done)}"
    assert {"gyro_bias_ekf", "operator_command"} <= {p.stem for p in core_modules()}


@pytest.mark.parametrize("line", ["from gimbal_kinematics.timing.stamps import judge",
                                  "from gimbal_kinematics import sync",
                                  "from gimbal_kinematics.timing.sync import StampPairs",
                                  "from gimbal_kinematics.timing import StampPairs",
                                  "from gimbal_kinematics import timing",
                                  "import gimbal_kinematics.timing",
                                  "import gimbal_kinematics.timing.input_policy",
                                  "from gimbal_kinematics.timing.stream_stats import StreamStats"])
def test_the_timing_import_check_finds_a_planted_import(tmp_path, line):
    planted = tmp_path / "core.py"
    planted.write_text(f"{line}\n")
    assert timing_imports(planted)
    planted.write_text("from gimbal_kinematics.maths.rotations import quat_mul\nimport numpy\n")
    assert not timing_imports(planted)


# ------------------------------------------------------------------ gimbal_kinematics's rooms
#: gimbal_kinematics's rooms, bottom-up: a module imports its own room and the rooms of a lower
#: level; rooms of one level are siblings and import neither each other. maths is the floor.
KINEMATICS_ROOM = {
    "maths": 0,     # rotations, earth, sighting chain, LOS, four-gimbal, free gyro, geo-pointing, Kalman, kernels
    "gimbal": 1,    # rigid-body models: the two-axis gimbal, the host state, the turret base
    "timing": 1,    # the one timing edge: stamps, orderings, stream statistics, input and control policies
    "params": 1,    # a node's parameters without ROS: the Param table, ROS 2 parameter files
    "cli": 2,       # the command-line edge: the error boundary of every command, gimbal-geometry
    "ros": 3,       # the import-isolated ROS edge
    "__init__": 4,  # the package: its conventions (docstring) and numba's cache key, set before any kernel
}
#: Packages of one level that import neither each other (nor list each other in package.xml).
SIBLINGS = ("gimbal_control", "gimbal_estimators")


def kinematics_room_violations(src: Path) -> list[str]:
    """Imports (function-local ones too) from one room of gimbal_kinematics into a room of the
    same or a higher level, and modules that sit in no room."""
    mods = module_index(src)
    kin = {m: p for m, p in mods.items() if m.split(".")[0] == "gimbal_kinematics"}
    bad = [f"{m}: not in a room of KINEMATICS_ROOM" for m in kin if room_of(m) not in KINEMATICS_ROOM]
    for m, p in kin.items():
        for t, _ in imports_in(m, p, mods):
            if t.split(".")[0] != "gimbal_kinematics" or room_of(t) == room_of(m) or room_of(m) not in KINEMATICS_ROOM:
                continue
            if room_of(t) not in KINEMATICS_ROOM or KINEMATICS_ROOM[room_of(t)] >= KINEMATICS_ROOM[room_of(m)]:
                bad.append(f"{m} ({room_of(m)}) imports {t} ({room_of(t)})")
    return bad


def test_gimbal_kinematics_keeps_every_module_in_a_room():
    root = SRC / "gimbal_kinematics" / "gimbal_kinematics"
    top = sorted(p.name for p in root.glob("*.py") if p.name != "__init__.py")
    rooms = sorted(p.name for p in root.iterdir() if (p / "__init__.py").is_file())
    assert not top, f"top-level modules of gimbal_kinematics (put each in a room): {top}"
    assert rooms == sorted(set(KINEMATICS_ROOM) - {"__init__"}), f"rooms on disk {rooms}, in KINEMATICS_ROOM " \
                                                                 f"{sorted(KINEMATICS_ROOM)}"


def test_gimbal_kinematics_rooms_import_only_their_own_room_or_rooms_below():
    bad = kinematics_room_violations(SRC)
    assert not bad, "imports of a room above or beside:\n" + "\n".join(bad)
    assert sum(m.startswith("gimbal_kinematics.maths.") for m in module_index(SRC)) > 10


@pytest.mark.parametrize("files, found", [
    ({"maths/a.py": "from ..timing.b import B\n", "timing/b.py": "B = 1\n"},
     ["gimbal_kinematics.maths.a (maths) imports gimbal_kinematics.timing.b (timing)"]),
    ({"timing/a.py": "def f():\n    from gimbal_kinematics.params import b\n    return b\n", "params/b.py": ""},
     ["gimbal_kinematics.timing.a (timing) imports gimbal_kinematics.params.b (params)"]),
    ({"ros/a.py": "from ..maths import b\n", "maths/b.py": "", "loose.py": ""},
     ["gimbal_kinematics.loose: not in a room of KINEMATICS_ROOM"]),
])
def test_the_room_check_finds_a_planted_import_of_a_room_above(tmp_path, files, found):
    """The checker above on a planted package: an import up (at the top or function-local),
    one sideways between siblings, and a module outside any room are each found; the
    allowed import down is not."""
    root = tmp_path / "gimbal_kinematics" / "gimbal_kinematics"
    for rel in ["__init__.py", *{f"{r.split('/')[0]}/__init__.py" for r in files if "/" in r}, *files]:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(files.get(rel, ""))
    assert kinematics_room_violations(tmp_path) == found


def test_gimbal_control_and_gimbal_estimators_are_siblings():
    """Neither imports the other (function-local imports count) nor lists the other in its
    package.xml: what both need (the Kalman steps) is gimbal_kinematics.maths."""
    import xml.etree.ElementTree as ET

    assert LEVEL[SIBLINGS[0]] == LEVEL[SIBLINGS[1]]
    bad = []
    for pkg, other in (SIBLINGS, SIBLINGS[::-1]):
        bad += [f"{p.relative_to(SRC)} imports {other}" for p in modules(pkg) if other in imports_of(p)]
        root = ET.parse(SRC / pkg / "package.xml").getroot()
        if other in {e.text for e in root.iter() if e.tag.endswith("depend")}:
            bad.append(f"{pkg}/package.xml depends on {other}")
    assert not bad, "\n".join(bad)
