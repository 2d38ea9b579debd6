"""What a campaign asks for, validated, and the runs it expands to.

A campaign is a scenario (and which of its variants), seeds, optional sweeps over node
parameters, a duration, a mode and an engine, given as a YAML file or as ``gimbal-campaign``
flags (flags override the file)::

    scenario: sighting_land_vehicle     # built-in name or scenario YAML
    variants: [ekf_off, ekf_on]          # default: every variant of the scenario
    seeds: 1-20                          # "1-20", "1,4,7-9", or a list of integers
    duration_s: 120.0                    # default: the scenario's
    mode: container                      # graph engine: container | processes
    engine: graph                        # graph (real nodes, gimbal-run) | core (one Python loop)
    set: {los_rate_controller.omega_n_hz: 20.0}   # fixed overrides, every run
    sweep:                               # node.param (or node.param[i]) -> values
      sensor_models.gimbal_gyro_bias_deg_h: "50:200:4"   # a:b:n grid (numpy.linspace)
      los_rate_controller.mode: [rate]                   # or a list of values
    sampling: grid                       # grid (Cartesian product) | sobol
    samples: 16                          # sobol: points (a power of 2), each sweep given as a:b bounds
    sample_seed: 0                       # sobol: scrambling seed
    keep_bags: all                       # all | failed | none
    timeout_s: 600                       # per run (default 120 s + 10 x duration)
    compress: true                       # zstd MCAP chunks in the bags

A swept value of a vector parameter (a list, e.g. ``gimbal_gyro_bias_deg_h`` [q, r]) sets
every element; ``node.param[i]`` sweeps element i alone. Values are typed as the node
declares them (an integer parameter takes integral grid points; Sobol points are rounded).

Every run is (variant, seed, swept values); its id is a hash of the scenario name, the
variant, the seed and the values (:func:`run_id`), so the same run gets the same id in any
campaign, which is what ``--resume`` relies on. What else shapes a run (the scenario file's
content, duration, mode, engine, fixed overrides) is the campaign's :meth:`fingerprint`: a
resumed campaign must have the same one.
"""
from __future__ import annotations

import copy
from collections import Counter
import dataclasses
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from gimbal_kinematics.cli_boundary import read_text

from ..core.core_loop import NoCoreError
from ..core.engine_run import check_engine
from ..graph.plan import check_nodes
from ..graph.registry import NODE_TYPES
from ..graph.scenario import Scenario, ScenarioError, check_param, load, variant

ENGINES = ("graph", "core")
MODES = ("container", "processes")
KEEP_BAGS = ("all", "failed", "none")
SAMPLINGS = ("grid", "sobol")
#: Parameters the orchestrator sets itself: a sweep of them would be silently overwritten.
OWNED_BY_ORCHESTRATOR = {"seed", "sim_rate_hz", "duration_s", "pace_topics", "wait_for_subscribers",
                         "subscriber_counts"}
_KEYS = {"scenario", "variants", "seeds", "duration_s", "mode", "engine", "set", "sweep", "sampling", "samples",
         "sample_seed", "keep_bags", "timeout_s", "compress"}
_TARGET = re.compile(r"^([A-Za-z_][\w]*)\.([A-Za-z_][\w]*)(?:\[(\d+)\])?$")


class CampaignError(ValueError):
    """The campaign is invalid; the message names the option or parameter at fault."""


@dataclass(frozen=True)
class Sweep:
    """One swept parameter: ``target`` ``node.param`` or ``node.param[i]``; ``values`` (grid
    or list) or ``bounds`` (low, high) for Sobol sampling."""

    target: str
    values: tuple[Any, ...] | None = None
    bounds: tuple[float, float] | None = None
    text: str = ""  # as given, for campaign.yaml


@dataclass(frozen=True)
class CampaignSpec:
    """A campaign as asked (module docstring); :func:`plan` validates it against the scenario."""

    scenario: str
    seeds: tuple[int, ...]
    variants: tuple[str, ...] = ()
    sweeps: tuple[Sweep, ...] = ()
    sampling: str = "grid"
    samples: int = 0
    sample_seed: int = 0
    duration_s: float | None = None
    mode: str = "container"
    engine: str = "graph"
    overrides: tuple[tuple[str, Any], ...] = ()
    keep_bags: str = "all"
    timeout_s: float | None = None
    compress: bool = True
    #: an experiment runner's campaign (:mod:`.experiment`) instead of a scenario's
    experiment: str = ""
    options: tuple[tuple[str, Any], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The campaign in its YAML form (what ``campaign.yaml`` holds)."""
        if self.experiment:
            return {"experiment": self.experiment, "variants": list(self.variants), "seeds": list(self.seeds),
                    "options": {k: v for k, v in self.options}, "mode": self.mode, "engine": self.engine,
                    "keep_bags": self.keep_bags, "timeout_s": self.timeout_s, "compress": self.compress}
        return {"scenario": self.scenario, "variants": list(self.variants), "seeds": list(self.seeds),
                "duration_s": self.duration_s, "mode": self.mode, "engine": self.engine,
                "set": {k: v for k, v in self.overrides},
                "sweep": {s.target: s.text if s.text else list(s.values or ()) for s in self.sweeps},
                "sampling": self.sampling, "samples": self.samples, "sample_seed": self.sample_seed,
                "keep_bags": self.keep_bags, "timeout_s": self.timeout_s, "compress": self.compress}


@dataclass(frozen=True)
class PlannedRun:
    """One run of a campaign: the single-run scenario it executes (None: an experiment
    runner's core run) and what identifies it."""

    run_id: str
    variant: str
    seed: int
    values: dict[str, Any]
    scenario: Scenario | None = field(repr=False)


@dataclass(frozen=True)
class CampaignPlan:
    spec: CampaignSpec
    base: Scenario | None       # None: an experiment runner's core runs
    runs: tuple[PlannedRun, ...]
    fingerprint: dict[str, Any]


# ------------------------------------------------------------------------ parsing
#: Seeds one campaign may list at all; :data:`LARGE_RUNS` more runs need ``--large``.
MAX_SEEDS = 1_000_000
LARGE_RUNS = 10_000
#: A campaign estimated (engine.estimate_wall_s) to take longer than this [s] needs ``--large``.
MAX_ESTIMATE_S = 24 * 3600.0
#: Wall seconds one worker spends per simulated second of a run, measured: docs/campaigns.md's
#: `gimbal-campaign sighting_land_vehicle --seeds 1-20` (40 runs of 120 s) took about 104 s per
#: run with the graph engine (container mode) and 13.5 s with --engine core.
WALL_PER_SIM_S = {"graph": 104.0 / 120.0, "core": 13.5 / 120.0}


def parse_seeds(text: Any, where: str = "--seeds") -> tuple[int, ...]:
    """Seeds from ``"1-20"``, ``"1,4,7-9"``, an integer or a list of integers; no repeats."""
    if isinstance(text, bool):
        raise CampaignError(f"{where}: expected seeds like 1-20 or 1,3,5, got {text!r}")
    if isinstance(text, int):
        items: list[Any] = [text]
    elif isinstance(text, list):
        items = text
    elif isinstance(text, str):
        items = [p.strip() for p in text.split(",")]
    else:
        raise CampaignError(f"{where}: expected seeds like 1-20 or 1,3,5, got {text!r}")
    seeds: list[int] = []
    for item in items:
        if isinstance(item, int) and not isinstance(item, bool):
            lo = hi = item
        elif isinstance(item, str) and re.fullmatch(r"\d+(-\d+)?", item):
            a, _, b = item.partition("-")
            lo, hi = int(a), int(b or a)
        else:
            raise CampaignError(f"{where}: malformed seed range {item!r} (expected N or A-B, integers >= 0)")
        if lo < 0 or hi < lo:
            raise CampaignError(f"{where}: malformed seed range {item!r} (needs 0 <= A <= B)")
        if len(seeds) + hi - lo + 1 > MAX_SEEDS:
            raise CampaignError(f"{where}: {item!r} makes more than {MAX_SEEDS:,} seeds, the most a campaign "
                                f"plans; split it into campaigns")
        seeds.extend(range(lo, hi + 1))
    if not seeds:
        raise CampaignError(f"{where}: no seeds")
    repeated = sorted(s for s, n in Counter(seeds).items() if n > 1)
    if repeated:
        raise CampaignError(f"{where}: seed(s) {repeated} given twice")
    return tuple(seeds)


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise CampaignError(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise CampaignError(f"{where}: {text!r} is not a finite number")
    return value


def parse_sweep(target: str, spec: Any, sampling: str = "grid") -> Sweep:
    """One sweep from ``target`` and its values: ``"a:b:n"`` (n points from a to b), ``"a:b"``
    (Sobol bounds), ``"v1,v2"`` or a YAML list of values, or one value."""
    where = f"sweep {target}"
    if not _TARGET.match(target):
        raise CampaignError(f"{where}: expected node.param or node.param[i]")
    if isinstance(spec, list):
        if not spec:
            raise CampaignError(f"{where}: empty list of values")
        if sampling == "sobol":
            raise CampaignError(f"{where}: Sobol sampling needs bounds a:b, not a list")
        return Sweep(target, values=tuple(spec))
    text = str(spec).strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) not in (2, 3) or any(not p.strip() for p in parts):
            raise CampaignError(f"{where}: malformed range {text!r} (expected a:b:n, or a:b with --sampling sobol)")
        lo, hi = _number(parts[0], where), _number(parts[1], where)
        if sampling == "sobol":
            if len(parts) == 3:
                raise CampaignError(f"{where}: with Sobol sampling give bounds a:b (the point count is --samples)")
            if not hi > lo:
                raise CampaignError(f"{where}: malformed range {text!r}: Sobol bounds need a < b")
            return Sweep(target, bounds=(lo, hi), text=text)
        if len(parts) == 2:
            raise CampaignError(f"{where}: malformed range {text!r}: a grid needs a point count, a:b:n")
        if not re.fullmatch(r"\s*\d+\s*", parts[2]) or int(parts[2]) < 2:
            raise CampaignError(f"{where}: malformed range {text!r}: n must be an integer >= 2")
        if lo == hi:
            raise CampaignError(f"{where}: malformed range {text!r}: a and b are equal")
        return Sweep(target, values=tuple(float(v) for v in np.linspace(lo, hi, int(parts[2]))), text=text)
    if sampling == "sobol":
        raise CampaignError(f"{where}: Sobol sampling needs bounds a:b, got {text!r}")
    try:
        values = [yaml.safe_load(v) for v in text.split(",")]
    except yaml.YAMLError as exc:
        raise CampaignError(f"{where}: values {text!r} are not valid YAML: {exc}") from exc
    if any(v is None for v in values):
        raise CampaignError(f"{where}: empty value in {text!r}")
    return Sweep(target, values=tuple(values), text=text)


#: an experiment runner's campaign as YAML (``CampaignSpec.to_dict``); duration_s joins the options
_EXPERIMENT_KEYS = {"experiment", "variants", "seeds", "options", "duration_s", "mode", "engine", "keep_bags",
                    "timeout_s", "compress"}
#: what a campaign directory's own ``campaign.yaml`` holds around the campaign it asked for
RECORD_KEYS = {"campaign", "fingerprint", "runs"}


def is_record(data: Any) -> bool:
    """Is ``data`` a campaign directory's record (``campaign.yaml``) rather than a campaign?"""
    return isinstance(data, dict) and isinstance(data.get("campaign"), dict) and set(data) <= RECORD_KEYS


def _experiment_from_mapping(data: dict[str, Any], where: str) -> CampaignSpec:
    unknown = set(data) - _EXPERIMENT_KEYS
    if unknown:
        raise CampaignError(f"{where}: unknown keys {sorted(unknown)} for an experiment campaign; "
                            f"allowed: {sorted(_EXPERIMENT_KEYS)}")
    options = dict(data.get("options") or {})
    if data.get("duration_s") is not None:
        options["duration_s"] = data["duration_s"]
    rest = {k: v for k, v in data.items() if k in ("mode", "engine", "keep_bags", "timeout_s", "compress")}
    scenario_form = spec_from_mapping({"scenario": "", "variants": data.get("variants") or [],
                                       "seeds": data.get("seeds", [0]), **rest}, where)
    return replace(scenario_form, experiment=str(data["experiment"]), options=tuple(sorted(options.items())))


def spec_from_mapping(data: Any, where: str = "campaign") -> CampaignSpec:
    """A :class:`CampaignSpec` from a YAML mapping (module docstring), a scenario's campaign or
    an experiment runner's (``experiment:``)."""
    if not isinstance(data, dict):
        raise CampaignError(f"{where}: a campaign is a YAML mapping")
    if "experiment" in data:
        return _experiment_from_mapping(data, where)
    unknown = set(data) - _KEYS
    if unknown:
        raise CampaignError(f"{where}: unknown keys {sorted(unknown)}; allowed: {sorted(_KEYS)}")
    if "scenario" not in data:
        raise CampaignError(f"{where}: missing 'scenario'")
    sampling = str(data.get("sampling", "grid"))
    if sampling not in SAMPLINGS:
        raise CampaignError(f"{where}: sampling must be one of {SAMPLINGS}, got {sampling!r}")
    sweeps = data.get("sweep") or {}
    overrides = data.get("set") or {}
    variants = data.get("variants") or []
    if not isinstance(sweeps, dict) or not isinstance(overrides, dict):
        raise CampaignError(f"{where}: 'sweep' and 'set' must map node.param to values")
    if isinstance(variants, str):
        variants = [variants]
    if not isinstance(variants, list) or not all(isinstance(v, str) for v in variants):
        raise CampaignError(f"{where}: 'variants' must be a list of variant names")
    kw: dict[str, Any] = {}
    for key in ("duration_s", "timeout_s"):
        if data.get(key) is not None:
            value = data[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise CampaignError(f"{where}: {key} must be a number > 0, got {value!r}")
            kw[key] = float(value)
    for key, choices in (("mode", MODES), ("engine", ENGINES), ("keep_bags", KEEP_BAGS)):
        if key in data:
            if data[key] not in choices:
                raise CampaignError(f"{where}: {key} must be one of {choices}, got {data[key]!r}")
            kw[key] = data[key]
    for key in ("samples", "sample_seed"):
        if key in data:
            value = data[key]
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise CampaignError(f"{where}: {key} must be an integer >= 0, got {value!r}")
            kw[key] = value
    if "compress" in data:
        if not isinstance(data["compress"], bool):
            raise CampaignError(f"{where}: compress must be true or false")
        kw["compress"] = data["compress"]
    return CampaignSpec(scenario=str(data["scenario"]), seeds=parse_seeds(data.get("seeds", [0]), f"{where}: seeds"),
                        variants=tuple(variants), sampling=sampling,
                        sweeps=tuple(parse_sweep(str(t), v, sampling) for t, v in sweeps.items()),
                        overrides=tuple((str(k), v) for k, v in overrides.items()), **kw)


def load_spec_file(path: Path) -> CampaignSpec:
    path = Path(path)
    if not path.is_file():
        raise CampaignError(f"campaign file {path}: no such file")
    try:
        data = yaml.safe_load(read_text(path, "campaign file"))
    except yaml.YAMLError as exc:
        raise CampaignError(f"campaign file {path}: not valid YAML: {' '.join(str(exc).split())}") from None
    if is_record(data):  # a campaign directory's campaign.yaml: the campaign it asked for, run anew
        data = data["campaign"]
    return spec_from_mapping(data, str(path))


@dataclass(frozen=True)
class RunTask:
    """One run, as shipped to a worker (picklable): the single-run scenario as YAML and how
    to run it. ``values`` are the swept values (target -> value)."""

    run_id: str
    campaign_dir: str
    scenario_yaml: str
    scenario_name: str
    variant: str
    seed: int
    values: dict[str, Any]
    engine: str
    mode: str
    compress: bool
    keep_bags: str
    timeout_s: float
    experiment: str = ""                  # an experiment runner's campaign (its name is scenario_name)
    options: dict[str, Any] = field(default_factory=dict)   # the runner's settings


#: A caller's run: (task, run_dir to create) -> the run's metrics (a metrics.json mapping).
RunFunction = Callable[[RunTask, Path], dict]

# ------------------------------------------------------------------------ planning
def run_id(scenario_name: str, variant_name: str, seed: int, values: dict[str, Any]) -> str:
    """The run's id: 16 hex digits of the SHA-256 of (scenario, variant, seed, values)."""
    text = json.dumps({"scenario": scenario_name, "variant": variant_name, "seed": seed, "values": values},
                      sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _typed(node: str, executable: str, param: str, index: int | None, value: Any, current: Any, where: str) -> Any:
    """``value`` as the node's parameter takes it: a scalar spread over a vector parameter
    (or put at ``index``), integral floats as integers for an integer parameter."""
    default = {p.name: p.default for p in NODE_TYPES[executable].params}.get(param)
    if isinstance(default, list):
        base = list(current if current is not None else default)
        if index is not None:
            if index >= len(base):
                raise CampaignError(f"{where}: index {index} out of range ({param} has {len(base)} elements)")
            base[index] = value
            value = base
        elif not isinstance(value, list):
            value = [value] * len(base)
    elif index is not None:
        raise CampaignError(f"{where}: {param} is not a vector parameter; drop [{index}]")
    if isinstance(default, int) and not isinstance(default, bool) and isinstance(value, float):
        if value != round(value):
            raise CampaignError(f"{where}: integer parameter {param} cannot take {value!r}")
        value = int(round(value))
    try:
        return check_param(node, executable, param, value)
    except ScenarioError as exc:
        raise CampaignError(f"{where}: {exc}") from None


def apply_value(scenario: Scenario, target: str, value: Any, where: str) -> Scenario:
    """``scenario`` with ``node.param`` (or ``node.param[i]``) set to ``value``, checked
    against the node's declaration; raises :class:`CampaignError` naming ``where``."""
    match = _TARGET.match(target)
    if not match:
        raise CampaignError(f"{where}: expected node.param or node.param[i], got {target!r}")
    node, param, index = match.group(1), match.group(2), match.group(3)
    if node not in scenario.nodes:
        raise CampaignError(f"{where}: no node {node!r} in scenario {scenario.name!r} "
                            f"(nodes: {', '.join(scenario.nodes)})")
    if param in OWNED_BY_ORCHESTRATOR:
        raise CampaignError(f"{where}: {param!r} is set by the orchestrator (use --seeds / --duration)")
    spec = scenario.nodes[node]
    typed = _typed(node, spec["executable"], param, None if index is None else int(index), value,
                   spec["params"].get(param), where)
    new = copy.deepcopy(scenario)
    new.nodes[node]["params"][param] = typed
    return new


def _points(spec: CampaignSpec) -> list[dict[str, Any]]:
    """The swept values of every point: the grid's product, or scrambled Sobol points."""
    if not spec.sweeps:
        return [{}]
    if spec.sampling == "grid":
        return [dict(zip([s.target for s in spec.sweeps], combo))
                for combo in itertools.product(*[s.values for s in spec.sweeps])]
    from scipy.stats import qmc

    n = spec.samples
    if n < 1 or n & (n - 1):
        raise CampaignError(f"--samples must be a power of 2 for Sobol sampling (balance), got {n}")
    unit = qmc.Sobol(d=len(spec.sweeps), scramble=True, seed=spec.sample_seed).random_base2(int(math.log2(n)))
    lo = [s.bounds[0] for s in spec.sweeps]
    hi = [s.bounds[1] for s in spec.sweeps]
    scaled = qmc.scale(unit, lo, hi)
    return [{s.target: float(row[i]) for i, s in enumerate(spec.sweeps)} for row in scaled]


def _round_for_int_params(base: Scenario, point: dict[str, Any]) -> dict[str, Any]:
    """Sobol points of integer parameters, rounded to the nearest integer."""
    out = {}
    for target, value in point.items():
        node, param = _TARGET.match(target).group(1, 2)
        spec = base.nodes.get(node)
        default = None if spec is None else \
            {p.name: p.default for p in NODE_TYPES[spec["executable"]].params}.get(param)
        is_int = isinstance(default, int) and not isinstance(default, bool)
        out[target] = int(round(value)) if is_int and isinstance(value, float) else value
    return out


def check_core_engine(scenario: Scenario) -> None:
    """Refuse (:class:`CampaignError`) a scenario the core loop cannot step."""
    try:
        check_engine(scenario)
    except NoCoreError as exc:
        raise CampaignError(f"--engine core: the core loop cannot step scenario {scenario.name!r} ({exc}); "
                            f"use --engine graph") from None


def _check_nodes(single: Scenario, variant_name: str) -> None:
    """What a run's nodes would refuse at start-up (each node's own checks on its final
    values, lists included), refused before the campaign starts any run."""
    try:
        check_nodes(single, f"variant {variant_name!r}: " if variant_name else "")
    except ScenarioError as exc:
        raise CampaignError(str(exc)) from None


def plan(spec: CampaignSpec) -> CampaignPlan:
    """Validate ``spec`` against its scenario and expand it into runs (variant × seed × point).
    Raises :class:`CampaignError` naming what is wrong; nothing is started or written."""
    if spec.experiment:
        raise CampaignError(f"experiment {spec.experiment!r}: an experiment campaign is planned by "
                            "its experiment (gimbal_sim.campaign.experiment.plan_experiment)")
    try:
        base = load(spec.scenario)
    except ScenarioError as exc:
        raise CampaignError(f"scenario: {exc}") from None
    if spec.duration_s is not None:
        base = dataclasses.replace(base, duration_s=spec.duration_s)
    for target, value in spec.overrides:
        base = apply_value(base, target, value, f"--set {target}")
    if spec.variants and not base.variants:
        raise CampaignError(f"--variant: scenario {base.name!r} has no variants")
    for name in spec.variants:
        if name not in base.variants:
            raise CampaignError(f"--variant: scenario {base.name!r} has no variant {name!r}; "
                                f"variants: {', '.join(base.variants)}")
    if len(set(spec.variants)) != len(spec.variants):
        raise CampaignError("--variant: a variant is given twice")
    if spec.sampling == "sobol" and not spec.sweeps:
        raise CampaignError("--sampling sobol needs at least one --sweep")
    if spec.sampling == "grid" and spec.samples:
        raise CampaignError("--samples is for --sampling sobol")
    targets = [s.target for s in spec.sweeps]
    if len(set(targets)) != len(targets):
        raise CampaignError(f"--sweep: a parameter is swept twice ({targets})")
    variant_names = list(spec.variants or base.variants) or [""]
    singles = {name: (variant(base, name) if name else base) for name in variant_names}
    for name, single in singles.items():
        for target, _ in spec.overrides:  # a variant's own override would silently win
            node_param = target.split("[")[0]
            if name and node_param in base.variants[name]:
                raise CampaignError(f"--set {target}: variant {name!r} sets it too")
        for sweep in spec.sweeps:
            if name and sweep.target.split("[")[0] in base.variants[name]:
                raise CampaignError(f"--sweep {sweep.target}: variant {name!r} sets it too")
            probe = sweep.values if sweep.values is not None else sweep.bounds
            for value in probe:  # every value is checked before anything runs
                apply_value(single, sweep.target, value, f"--sweep {sweep.target}")
        # the --set values as the nodes would take them; a swept point a node refuses is a
        # failed run, recorded, and the campaign carries on
        _check_nodes(single, name)
        if spec.engine == "core":
            check_core_engine(single)
    runs = []
    for point in _points(spec):
        point = _round_for_int_params(base, point)
        swept = {}
        for name, single in singles.items():
            swept[name] = single
            for target, value in point.items():
                swept[name] = apply_value(swept[name], target, value, f"--sweep {target}")
        # seed by seed, every variant of a seed together: a campaign stopped halfway has
        # the same seeds in each variant (and --resume carries on in that order)
        for seed in spec.seeds:
            for name, scenario in swept.items():
                seeded = dataclasses.replace(scenario, seed=seed)
                runs.append(PlannedRun(run_id(base.name, name, seed, point), name, seed, dict(point), seeded))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):
        raise CampaignError("two runs of the campaign are the same run (repeated sweep values?)")
    return CampaignPlan(spec, base, tuple(runs), fingerprint(spec, base))


def fingerprint(spec: CampaignSpec, base: Scenario) -> dict[str, Any]:
    """What, besides (variant, seed, values), shapes every run: a resumed campaign must match."""
    return {"scenario": base.name, "scenario_sha256": hashlib.sha256(base.to_yaml().encode()).hexdigest()[:16],
            "duration_s": base.duration_s, "mode": spec.mode if spec.engine == "graph" else None,
            "engine": spec.engine, "set": {k: v for k, v in spec.overrides}}
