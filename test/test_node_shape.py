"""One node shape, in code: the plumbing every node shares lives in the ROS edge
(``gimbal_kinematics.ros.node_edge``), stamps in the input policies, maths in the cores; a
node file holds its topics, its core and its serialisation, so it stays short. Read with
Python's ``ast`` and plain text search, no ROS."""
from __future__ import annotations

import ast
import io
import tokenize
from pathlib import Path

import pytest

from conftest import REPO_ROOT
from test_architecture import core_modules

SRC = REPO_ROOT / "src"
EDGE = SRC / "gimbal_kinematics" / "gimbal_kinematics" / "ros" / "node_edge.py"
NODE_FILES = sorted(SRC.rglob("*_node.py"))
MAX_NODE_LINES = 150
#: The node docs/architecture.md names as the one to copy.
MODEL_NODE, MODEL_NODE_LINES = SRC / "gimbal_estimators" / "gimbal_estimators" / "gyro_bias_ekf_node.py", 120
#: Nodes not yet on the shared edge's shape, with what keeps them long. The list only shrinks.
OVERSIZED: dict[str, str] = {}
#: Stamp, clock-jump and queue logic, by the names it goes by in code.
STAMP_NAMES = frozenset({"judge", "StampGate", "_accept_stamp", "_stamp_ok", "clock_jump_s", "clock_jump_ns",
                         "_jump_ns", "JUMPED_BACK", "rejected_out_of_order", "_drain", "_interp", "_pending",
                         "max_pending", "StampOrder", "StepGroups", "StampPairs"})
#: Cores whose stamp, clock-jump or queue logic has not moved to their node's input policy
#: yet, each with what stays. The list only shrinks.
CORES_WITH_STAMP_LOGIC: dict[str, str] = {}
#: Fields of a node's timing policy: the node's own parameters, never a core's.
POLICY_FIELDS = frozenset({"clock_jump_s"})


def stamp_names(text: str) -> set[str]:
    """The :data:`STAMP_NAMES` used in ``text``'s code (names, not strings or comments)."""
    return {tok.string for tok in tokenize.generate_tokens(io.StringIO(text).readline)
            if tok.type == tokenize.NAME and tok.string in STAMP_NAMES}


def code_lines(path: Path) -> int:
    """Lines of ``path`` without its module docstring."""
    text = path.read_text()
    body = ast.parse(text).body
    doc = 0
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        doc = body[0].end_lineno - body[0].lineno + 1
    return len(text.splitlines()) - doc


def test_the_diagnostics_throttle_lives_in_the_shared_edge_alone():
    assert "_next_diag_ns" in EDGE.read_text()
    elsewhere = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py") if p != EDGE and "_next_diag_ns" in p.read_text()]
    assert not elsewhere, f"a diagnostics throttle of its own (use NodeEdge.diagnostics): {elsewhere}"


def test_every_node_file_is_short_without_its_docstring():
    assert len(NODE_FILES) >= 15
    lines = {p.stem: code_lines(p) for p in NODE_FILES}
    long = {stem: n for stem, n in lines.items() if n >= MAX_NODE_LINES and stem not in OVERSIZED}
    assert not long, f"node files of {MAX_NODE_LINES} lines or more without the docstring: {long}"
    done = sorted(stem for stem in OVERSIZED if lines[stem] < MAX_NODE_LINES)
    assert not done, f"short now; drop them from OVERSIZED: {done}"
    assert code_lines(MODEL_NODE) < MODEL_NODE_LINES


def test_the_node_to_copy_is_named_in_the_architecture_page():
    page = (REPO_ROOT / "docs" / "architecture.md").read_text()
    assert str(MODEL_NODE.relative_to(REPO_ROOT)) in page and "node_edge.py" in page


def test_the_controller_and_estimator_nodes_are_on_the_shared_edge():
    nodes = [p for p in NODE_FILES if p.parts[-3] in ("gimbal_estimators", "gimbal_control")]
    assert len(nodes) == 9
    off = [p.stem for p in nodes if "NodeEdge(" not in p.read_text() or "NodeIo(" in p.read_text()]
    assert not off, f"nodes with plumbing of their own instead of NodeEdge: {off}"


def test_no_stamp_clock_jump_or_queue_logic_in_the_cores():
    found = {p.stem: sorted(stamp_names(p.read_text())) for p in core_modules()}
    found = {stem: names for stem, names in found.items() if names}
    bad = {stem: names for stem, names in found.items() if stem not in CORES_WITH_STAMP_LOGIC}
    assert not bad, f"stamp, clock-jump or queue logic in cores (it belongs to the input policy): {bad}"
    done = sorted(set(CORES_WITH_STAMP_LOGIC) - set(found))
    assert not done, f"clean now; drop them from CORES_WITH_STAMP_LOGIC: {done}"


def core_parameter_fields(text: str) -> dict[str, set[str]]:
    """Fields of :data:`POLICY_FIELDS` declared by the classes of ``text`` that are not a
    node's own parameters (a class named ``*NodeParams``), by class name."""
    found: dict[str, set[str]] = {}
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef) and not node.name.endswith("NodeParams"):
            names = {s.target.id for s in node.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)}
            if names & POLICY_FIELDS:
                found[node.name] = names & POLICY_FIELDS
    return found


def test_core_parameters_carry_no_timing_policy():
    """A core's parameters (in its module or in the node's ``*_params`` module) leave the
    clock-jump limit to the node, which builds its input policy from it once."""
    paths = [p for pkg in ("gimbal_estimators", "gimbal_control") for p in (SRC / pkg / pkg).glob("*.py")
             if not p.stem.endswith("_node") and p.stem not in CORES_WITH_STAMP_LOGIC]
    bad = {f"{p.stem}.{cls}": sorted(names)
           for p in paths for cls, names in core_parameter_fields(p.read_text()).items()}
    assert not bad, f"core parameters with the node's timing policy (declare it in the *NodeParams): {bad}"
    planted = "class CoreParams:\n    clock_jump_s: float = 1.0\nclass XNodeParams:\n    clock_jump_s: float = 1.0\n"
    assert core_parameter_fields(planted) == {"CoreParams": {"clock_jump_s"}}


@pytest.mark.parametrize("text", ["if judge(t, last, 0.5) is Stamp.OK:", "self._drain()",
                                  "jump = self.params.clock_jump_s", "partner = self._pending[1].pop(key)"])
def test_the_stamp_search_finds_planted_logic(text):
    assert stamp_names(text)
    assert not stamp_names("self.judgement = interpolate(stamps)  # judge the clock_jump_s\n\"StampOrder\"\n")
