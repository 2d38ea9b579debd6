"""Scenarios: which nodes run with which parameters, for how long, with which seed.

A scenario is a YAML mapping (``yaml.safe_load``), built in (``gimbal_sim/graph/scenarios/``) or
the user's own file::

    name: sim_open_loop
    description: one line for --list
    duration_s: 10.0
    sim_rate_hz: 1000.0
    seed: 0
    record: all            # or a list of topics
    record_rates_hz: {}    # optional: topic -> rate [Hz] it is recorded at (runs of hours; bag.record_rates)
    report: generic        # which report gimbal-report writes
    nodes:
      vehicle_dynamics:    # node name
        executable: vehicle_dynamics
        params: {profile: paper1_land_vehicle}
        remap: {}          # topic remappings, from: to
    variants:              # optional: run the scenario once per variant ...
      feedback_off: {los_rate_controller.feedback: false}
      feedback_on:  {los_rate_controller.feedback: true, seed: 3}   # also sim_rate_hz, record
    comparison: bias_feedback   # ... and compare the runs with this report
    prelude:               # optional (also as a variant's override): run another scenario first
      scenario: rotational_ins_alignment   # built-in name or YAML file
      variant: rotation_on                 # optional
      duration_s: 600.0                    # optional (default: that scenario's)
      hand_off: alignment_to_navigation    # turns its run into parameters of this one
      params: {sensor_models.platform_gyro_bi_deg_h: 0.01}   # optional: node.param of its run
                           # (--set prelude.node.param=value adds one)

Everything is validated before anything starts: unknown keys, executables or parameters,
and values of the wrong type are refused with a message naming them.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from gimbal_kinematics.params.file import ParamsFileError, blocks, load_ros_yaml

from .registry import NODE_TYPES

BUILTIN_DIR = Path(__file__).parent / "scenarios"


_TOP_KEYS = {"name", "description", "duration_s", "sim_rate_hz", "seed", "record", "report", "nodes", "variants",
             "comparison", "prelude", "record_rates_hz"}
_PRELUDE_KEYS = {"scenario", "variant", "duration_s", "hand_off", "params"}
#: ``--set`` / override prefix of a parameter of the prelude's run: ``prelude.node.param``
PRELUDE_PREFIX = "prelude."
_NODE_KEYS = {"executable", "params", "remap"}


class ScenarioError(ValueError):
    """A scenario, or an override of it, is invalid; the message says what and where."""


@dataclass
class Scenario:
    name: str
    description: str
    duration_s: float
    sim_rate_hz: float
    seed: int
    record: str | list[str]
    report: str
    nodes: dict[str, dict[str, Any]]
    #: variant name -> overrides ("node.param" or "seed" -> value), in run order
    variants: dict[str, dict[str, Any]] = field(default_factory=dict)
    comparison: str = ""
    #: a scenario run first, whose run hands over to this one (gimbal-run; keys: _PRELUDE_KEYS)
    prelude: dict[str, Any] | None = None
    #: topic -> the rate [Hz] it is recorded at, by stamp (:mod:`gimbal_sim.bag.record_rates`); others: all
    record_rates_hz: dict[str, float] = field(default_factory=dict)

    def to_yaml(self) -> str:
        data = {"name": self.name, "description": self.description, "duration_s": self.duration_s,
                "sim_rate_hz": self.sim_rate_hz, "seed": self.seed, "record": self.record,
                "report": self.report, "nodes": self.nodes}
        if self.variants:
            data.update(variants=self.variants, comparison=self.comparison)
        if self.prelude:
            data["prelude"] = self.prelude
        if self.record_rates_hz:
            data["record_rates_hz"] = dict(self.record_rates_hz)
        return yaml.safe_dump(data, sort_keys=False)


def builtin_scenarios() -> dict[str, Path]:
    return {p.stem: p for p in sorted(BUILTIN_DIR.glob("*.yaml"))}


def describe_builtins() -> list[tuple[str, str]]:
    return [(name, str(yaml.safe_load(path.read_text()).get("description", ""))) for name, path in
            builtin_scenarios().items()]


def load(spec: str) -> Scenario:
    """A built-in scenario by name, or a scenario YAML file by path; validated."""
    path = builtin_scenarios().get(spec)
    if path is None:
        path = Path(spec)
        if not (path.suffix in (".yaml", ".yml") and path.is_file()):
            known = ", ".join(builtin_scenarios()) or "none"
            raise ScenarioError(f"unknown scenario {spec!r}: not built in ({known}) and not a YAML file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {exc}") from exc
    return validate(data, str(path))


def _number(where: str, value: Any, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: expected a number, got {value!r}")
    if positive and not value > 0:
        raise ScenarioError(f"{where}: must be > 0, got {value!r}")
    return float(value)


def check_param(node: str, executable: str, name: str, value: Any) -> Any:
    """Validate one node parameter against its declaration; returns the value typed as
    declared (an int is accepted for a float parameter)."""
    table = {n: p for p in NODE_TYPES[executable].params for n in (p.name, *p.aliases)}
    if name not in table:
        raise ScenarioError(f"node {node!r} ({executable}) has no parameter {name!r}; "
                            f"known: {', '.join(sorted(table))}")
    default = table[name].default
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, str):
        ok = isinstance(value, str)
    else:
        ok = isinstance(value, list)
        if ok and default:
            kind = type(default[0])
            ok = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) if kind is float \
                else all(isinstance(v, kind) for v in value)
            value = [float(v) for v in value] if ok and kind is float else value
        elif ok:
            ok = all(isinstance(v, str) for v in value)
    if not ok:
        raise ScenarioError(f"node {node!r}: parameter {name!r} = {value!r} should be like {default!r}")
    why = table[name].refusal(value)
    if why:
        raise ScenarioError(f"node {node!r}: parameter {name!r} = {why}")
    return value


def validate(data: Any, where: str = "scenario") -> Scenario:
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: a scenario is a YAML mapping")
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise ScenarioError(f"{where}: unknown keys {sorted(unknown)}; allowed: {sorted(_TOP_KEYS)}")
    for key in ("name", "nodes", "duration_s"):
        if key not in data:
            raise ScenarioError(f"{where}: missing {key!r}")
    nodes = data["nodes"]
    if not isinstance(nodes, dict) or not nodes:
        raise ScenarioError(f"{where}: 'nodes' must map node names to their settings")
    checked: dict[str, dict[str, Any]] = {}
    for node, spec in nodes.items():
        spec = spec or {}
        if not isinstance(spec, dict) or set(spec) - _NODE_KEYS:
            raise ScenarioError(f"{where}: node {node!r}: settings must be a mapping with keys {sorted(_NODE_KEYS)}")
        executable = spec.get("executable", node)
        if executable not in NODE_TYPES:
            raise ScenarioError(f"{where}: node {node!r}: unknown executable {executable!r}; "
                                f"known: {', '.join(sorted(NODE_TYPES))}")
        params = spec.get("params") or {}
        remap = spec.get("remap") or {}
        if not isinstance(params, dict) or not isinstance(remap, dict):
            raise ScenarioError(f"{where}: node {node!r}: 'params' and 'remap' must be mappings")
        checked[node] = {"executable": executable,
                         "params": {k: check_param(node, executable, k, v) for k, v in params.items()},
                         "remap": {str(k): str(v) for k, v in remap.items()}}
    if "bag_recorder" in {s["executable"] for s in checked.values()}:
        raise ScenarioError(f"{where}: the orchestrator adds the recorder itself; remove it from 'nodes'")
    record = _record(data.get("record", "all"), where)
    rates = data.get("record_rates_hz") or {}
    if not isinstance(rates, dict) or not all(isinstance(t, str) and t.startswith("/") and not isinstance(r, bool)
                                              and isinstance(r, (int, float)) and 0 <= r < float("inf")
                                              for t, r in rates.items()):
        raise ScenarioError(f"{where}: 'record_rates_hz' must map topics (/...) to rates [Hz] >= 0")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ScenarioError(f"{where}: 'seed' must be an integer >= 0")
    scenario = Scenario(name=str(data["name"]), description=str(data.get("description", "")),
                        duration_s=_number(f"{where}: duration_s", data["duration_s"]),
                        sim_rate_hz=_number(f"{where}: sim_rate_hz", data.get("sim_rate_hz", 1000.0)),
                        seed=seed, record=record, report=str(data.get("report", "generic")), nodes=checked,
                        record_rates_hz={t: float(r) for t, r in rates.items()})
    variants = data.get("variants") or {}
    if not isinstance(variants, dict) or not all(isinstance(v, dict) for v in variants.values()):
        raise ScenarioError(f"{where}: 'variants' must map variant names to mappings of overrides")
    for name, overrides in variants.items():
        if not str(name).replace("_", "").replace("-", "").isalnum():
            raise ScenarioError(f"{where}: variant name {name!r} must be letters, digits, '_' or '-'")
        for key, value in overrides.items():
            override(scenario, key, value, f"{where}: variant {name!r}")
    comparison = str(data.get("comparison", ""))
    if variants and not comparison:
        raise ScenarioError(f"{where}: a scenario with 'variants' needs a 'comparison' report")
    prelude = _prelude(data["prelude"], f"{where}: prelude") if "prelude" in data else None
    return replace(scenario, variants={str(k): dict(v) for k, v in variants.items()}, comparison=comparison,
                   prelude=prelude)


def _record(value: Any, where: str) -> str | list[str]:
    """A checked ``record``: 'all' or a list of topics."""
    if value != "all" and not (isinstance(value, list) and all(isinstance(t, str) for t in value)):
        raise ScenarioError(f"{where}: 'record' must be 'all' or a list of topics")
    return value if value == "all" else list(value)


def _prelude(value: Any, where: str) -> dict[str, Any]:
    """A checked ``prelude`` mapping (module docstring); the scenario and hand-off it names
    are looked up when it runs."""
    if not isinstance(value, dict) or set(value) - _PRELUDE_KEYS or not {"scenario", "hand_off"} <= set(value):
        raise ScenarioError(f"{where}: expected a mapping with 'scenario' and 'hand_off' (optional 'variant', "
                            f"'duration_s'), got {value!r}")
    out = {k: str(value[k]) for k in ("scenario", "variant", "hand_off") if k in value}
    if "duration_s" in value:
        out["duration_s"] = _number(f"{where}: duration_s", value["duration_s"])
    if "params" in value:
        params = value["params"]
        if not isinstance(params, dict) or not all(isinstance(k, str) and "." in k for k in params):
            raise ScenarioError(f"{where}: 'params' must map node.param to a value, got {params!r}")
        out["params"] = dict(params)
    return out


def prelude_base(spec: dict[str, Any]) -> Scenario:
    """The scenario a ``prelude`` mapping names: its scenario, its variant, its ``params``;
    refuses a scenario with variants when the mapping names none."""
    first = load(spec["scenario"])
    if "variant" in spec:
        first = variant(first, spec["variant"])
    elif first.variants:
        raise ScenarioError(f"prelude: scenario {first.name!r} has variants ({', '.join(first.variants)}); "
                            f"name one with 'variant'")
    for key, value in spec.get("params", {}).items():
        first = override(first, key, value, f"prelude {spec['scenario']}: params")
    return first


def _prelude_param(scenario: Scenario, key: str, value: Any, where: str) -> Scenario:
    """``prelude.node.param``: a parameter of the prelude's run (the same sensors in both runs
    of a chain, say), checked against the prelude's scenario and kept in its ``params``."""
    if not scenario.prelude:
        raise ScenarioError(f"{where}: {key!r} sets a parameter of the prelude, and {scenario.name!r} has none")
    target = key[len(PRELUDE_PREFIX):]
    checked = override(prelude_base(scenario.prelude), target, value, where)
    node, _, param = target.partition(".")
    params = {**scenario.prelude.get("params", {}), target: checked.nodes[node]["params"][param]}
    return replace(scenario, prelude={**scenario.prelude, "params": params})


def override(scenario: Scenario, key: str, value: Any, where: str) -> Scenario:
    """``scenario`` with one override applied: ``seed``, ``sim_rate_hz``, ``record`` (a
    variant that publishes other topics), ``prelude``, ``prelude.node.param`` or ``node.param``."""
    if key == "record":
        return replace(scenario, record=_record(value, f"{where}: record"))
    if key == "sim_rate_hz":
        return replace(scenario, sim_rate_hz=_number(f"{where}: sim_rate_hz", value))
    if key == "prelude":
        return replace(scenario, prelude=_prelude(value, f"{where}: prelude"))
    if key.startswith(PRELUDE_PREFIX):
        return _prelude_param(scenario, key, value, where)
    if key == "seed":
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ScenarioError(f"{where}: 'seed' must be an integer >= 0, got {value!r}")
        return replace(scenario, seed=value)
    node, dot, param = str(key).partition(".")
    if not dot or node not in scenario.nodes:
        raise ScenarioError(f"{where}: override {key!r} is not 'seed', 'sim_rate_hz', 'record', 'prelude' or "
                            f"'node.param' of a node in the "
                            f"scenario (nodes: {', '.join(scenario.nodes)})")
    new = copy.deepcopy(scenario)
    spec = new.nodes[node]
    spec["params"][param] = check_param(node, spec["executable"], param, value)
    return new


def variant(scenario: Scenario, name: str) -> Scenario:
    """The single-run scenario of variant ``name`` (named ``<scenario>:<variant>``)."""
    if name not in scenario.variants:
        raise ScenarioError(f"scenario {scenario.name!r} has no variant {name!r}; "
                            f"variants: {', '.join(scenario.variants) or 'none'}")
    single = replace(scenario, variants={}, comparison="")
    for key, value in scenario.variants[name].items():
        single = override(single, key, value, f"variant {name!r}")
    return replace(single, name=f"{scenario.name}:{name}")


def apply_set(scenario: Scenario, assignment: str) -> Scenario:
    """``--set node.param=value`` (value parsed as YAML); returns a new scenario."""
    target, sep, text = assignment.partition("=")
    node, dot, param = target.partition(".")
    if not sep or not dot or not node or not param:
        raise ScenarioError(f"--set {assignment!r}: expected node.param=value")
    if node not in scenario.nodes and not target.startswith(PRELUDE_PREFIX):
        raise ScenarioError(f"--set {assignment!r}: no node {node!r} in scenario (nodes: {', '.join(scenario.nodes)})")
    try:
        value = load_ros_yaml(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"--set {assignment!r}: value is not valid YAML: {exc}") from exc
    return override(scenario, target, value, f"--set {assignment!r}")


def apply_params_file(scenario: Scenario, path: Path) -> Scenario:
    """``--params-file``: a ROS 2 parameter file applied as ``node.param`` overrides, as ROS 2
    applies it to the scenario's nodes (all in the root namespace: ``/<node>``): every block
    whose name or wildcard matches a node, in file order (:mod:`.params_file`); returns a new
    scenario.

    A block of a toolkit node this scenario does not run is left alone, as that node would
    read it (gimbal-allan's filters.yaml has one per filter); a block that matches no node and
    names none (a misspelling, another namespace) is refused naming the nodes. A wildcard
    block's parameter goes to the matched nodes that declare it, and must be declared by one.
    Unknown, mistyped or out-of-range values raise :class:`ScenarioError` saying which."""
    where = f"--params-file {path}"
    try:
        data = load_ros_yaml(Path(path).read_text())
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot read it: {exc}") from exc
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{where}: not a YAML text file: {exc}") from exc
    try:
        found = blocks(data, where)
    except ParamsFileError as exc:
        raise ScenarioError(str(exc)) from exc
    fqns = {f"/{n}": n for n in scenario.nodes}
    elsewhere = {f"/{n}" for n in NODE_TYPES} - set(fqns)
    applied = 0
    for block in found:
        targets = [n for fqn, n in fqns.items() if block.matches(fqn)]
        if not targets:
            if not block.wildcard and block.pattern in elsewhere:
                continue
            raise ScenarioError(f"{where}: node block {block.pattern!r} matches no node of the scenario (its nodes: "
                                f"{', '.join(fqns)}; other nodes of the toolkit: {', '.join(sorted(elsewhere))})")
        applied += 1
        for param, value in block.params.items():
            scenario = _apply_block_param(scenario, block.wildcard, targets, param, value, where)
    if not applied:
        raise ScenarioError(f"{where}: none of its nodes ({', '.join(b.pattern for b in found)}) is in the scenario "
                            f"(nodes: {', '.join(scenario.nodes)})")
    return scenario


def _apply_block_param(scenario: Scenario, wildcard: bool, targets: list[str], param: str, value: Any,
                       where: str) -> Scenario:
    if wildcard:
        # as a node ignores an undeclared parameter of a /** block, but one node must want it
        declared = [n for n in targets if param in {a for p in NODE_TYPES[scenario.nodes[n]["executable"]].params
                                                    for a in (p.name, *p.aliases)}]
        if not declared:
            raise ScenarioError(f"{where}: parameter {param!r} of a wildcard block is declared by none of the nodes "
                                f"it matches ({', '.join(targets)})")
        targets = declared
    for node in targets:
        try:
            scenario = override(scenario, f"{node}.{param}", value, where)
        except ScenarioError as exc:
            raise ScenarioError(f"{where}: {exc}" if where not in str(exc) else str(exc)) from exc
    return scenario
