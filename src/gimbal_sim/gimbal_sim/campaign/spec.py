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
    dispersions:                         # node.param (or node.param[i]) -> its distribution (dispersion.py)
      sensor_models.gimbal_gyro_bias_deg_h[0]: normal(100, 30)
      sensor_models.ins_heading_rms_deg: {dist: uniform, low: 0.1, high: 0.3}
    dispersion_sampling: lhs             # random | lhs | sobol: one draw per seed, seeded by sample_seed
    sensitivity: sobol                   # sobol (Saltelli, samples = N, a power of 2) | morris (samples
                                         # trajectories): the design over the dispersions and the seed
    requirements:                        # order-statistics verdicts (order_stats.py)
      - {metric: sighting.final_drift_deg.azimuth, abs: true, max: 1.0, p: 0.9, c: 0.9}
    keep_bags: all                       # all | failed | none
    timeout_s: 600                       # per run (default 120 s + 10 x duration)
    compress: true                       # zstd MCAP chunks in the bags

A swept value of a vector parameter (a list, e.g. ``gimbal_gyro_bias_deg_h`` [q, r]) sets
every element; ``node.param[i]`` sweeps element i alone. Values are typed as the node
declares them (an integer parameter takes integral grid points; Sobol points are rounded).

Every run is (variant, seed, swept values); its id is a hash of the scenario name, the
variant, the seed and the values (:func:`run_id`), so the same run gets the same id in any
campaign, which is what ``--resume`` relies on. A dispersed value is one of the run's values:
the n-th seed's runs draw the n-th point of the sampling (every variant and sweep point the
same draw); a sensitivity campaign takes its seeds and values from its design. What else shapes a run (the scenario file's
content, duration, mode, engine, fixed overrides) is the campaign's :meth:`fingerprint`: a
resumed campaign must have the same one.
"""
from __future__ import annotations

import copy
import dataclasses
import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import yaml

from gimbal_kinematics.cli.boundary import read_text

from ..core.core_loop import NoCoreError
from ..core.engine_run import check_engine
from ..graph.plan import check_nodes
from ..graph.registry import NODE_TYPES
from ..graph.scenario import PRELUDE_PREFIX, Scenario, ScenarioError, check_param, load, override, variant
from . import sensitivity as sensitivity_design
from . import order_stats
from .parsing import _TARGET, CampaignError, Sweep, parse_seeds, parse_sweep
from .dispersion import Distribution, DispersionError, draws, parse_review
from .order_stats import Requirement

ENGINES = ("graph", "core")
MODES = ("container", "processes")
KEEP_BAGS = ("all", "failed", "none")
SAMPLINGS = ("grid", "sobol")
#: Parameters the orchestrator sets itself: a sweep of them would be silently overwritten.
OWNED_BY_ORCHESTRATOR = {"seed", "sim_rate_hz", "duration_s", "pace_topics", "wait_for_subscribers",
                         "subscriber_counts"}
_KEYS = {"scenario", "variants", "seeds", "duration_s", "mode", "engine", "set", "sweep", "sampling", "samples",
         "sample_seed", "keep_bags", "timeout_s", "compress", "dispersions", "dispersion_sampling", "requirements",
         "sensitivity"}


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
    dispersions: tuple[tuple[str, Distribution], ...] = ()
    dispersion_sampling: str = "random"
    requirements: tuple[Requirement, ...] = ()
    sensitivity: str = ""      # "" | sobol | morris (sensitivity.METHODS)

    def review_dict(self) -> dict[str, Any]:
        """The dispersions, requirements and sensitivity, in YAML form (only those given)."""
        out: dict[str, Any] = {}
        if self.dispersions:
            out["dispersions"] = {t: d.to_text() for t, d in self.dispersions}
            out["dispersion_sampling"] = self.dispersion_sampling
        if self.requirements:
            out["requirements"] = [r.to_dict() for r in self.requirements]
        if self.sensitivity:
            out["sensitivity"] = self.sensitivity
        return out

    def to_dict(self) -> dict[str, Any]:
        """The campaign in its YAML form (what ``campaign.yaml`` holds)."""
        if self.experiment:
            return {"experiment": self.experiment, "variants": list(self.variants), "seeds": list(self.seeds),
                    "options": {k: v for k, v in self.options}, "mode": self.mode, "engine": self.engine,
                    "keep_bags": self.keep_bags, "timeout_s": self.timeout_s, "compress": self.compress,
                    **({"set": {k: v for k, v in self.overrides}} if self.overrides else {}), **self.review_dict()}
        return {"scenario": self.scenario, "variants": list(self.variants), "seeds": list(self.seeds),
                "duration_s": self.duration_s, "mode": self.mode, "engine": self.engine,
                "set": {k: v for k, v in self.overrides},
                "sweep": {s.target: s.text if s.text else list(s.values or ()) for s in self.sweeps},
                "sampling": self.sampling, "samples": self.samples, "sample_seed": self.sample_seed,
                "keep_bags": self.keep_bags, "timeout_s": self.timeout_s, "compress": self.compress,
                **self.review_dict()}


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
    #: a sensitivity campaign's design: per variant, the run id of each design row, in order
    design: dict[str, list[str]] = field(default_factory=dict)


# ------------------------------------------------------------------------ parsing
#: More runs than this need ``--large`` (a campaign lists at most :data:`.parsing.MAX_SEEDS` seeds).
LARGE_RUNS = 10_000
#: A campaign estimated (engine.estimate_wall_s) to take longer than this [s] needs ``--large``.
MAX_ESTIMATE_S = 24 * 3600.0
#: Wall seconds one worker spends per simulated second of a run, measured: docs/campaigns.md's
#: `gimbal-campaign sighting_land_vehicle --seeds 1-20` (40 runs of 120 s) took about 104 s per
#: run with the graph engine (container mode) and 13.5 s with --engine core.
WALL_PER_SIM_S = {"graph": 104.0 / 120.0, "core": 13.5 / 120.0}


#: an experiment runner's campaign as YAML (``CampaignSpec.to_dict``); duration_s joins the options
_EXPERIMENT_KEYS = {"experiment", "variants", "seeds", "options", "duration_s", "mode", "engine", "keep_bags",
                    "timeout_s", "compress", "requirements", "set"}
#: what a campaign directory's own ``campaign.yaml`` holds around the campaign it asked for
RECORD_KEYS = {"campaign", "fingerprint", "runs", "design"}


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
    rest = {k: v for k, v in data.items() if k in ("mode", "engine", "keep_bags", "timeout_s", "compress", "set")}
    scenario_form = spec_from_mapping({"scenario": "", "variants": data.get("variants") or [],
                                       "seeds": data.get("seeds", [0]), **rest}, where)
    return replace(scenario_form, experiment=str(data["experiment"]), options=tuple(sorted(options.items())),
                   requirements=parse_requirements(data.get("requirements"), where))


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
                        overrides=tuple((str(k), v) for k, v in overrides.items()),
                        requirements=parse_requirements(data.get("requirements"), where), **_review_keys(data, where),
                        **kw)


def parse_requirements(data: Any, where: str) -> tuple[Requirement, ...]:
    """The requirements of a campaign (:func:`.order_stats.parse_requirements`)."""
    try:
        return order_stats.parse_requirements(data, where)
    except order_stats.RequirementError as exc:
        raise CampaignError(str(exc)) from None


def _review_keys(data: dict[str, Any], where: str) -> dict[str, Any]:
    try:
        return parse_review(data, where)
    except DispersionError as exc:
        raise CampaignError(str(exc)) from None


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
    against the node's declaration (``prelude.node.param``: a parameter of the prelude's run);
    raises :class:`CampaignError` naming ``where``."""
    if target.startswith(PRELUDE_PREFIX):
        try:
            return override(scenario, target, value, where)
        except ScenarioError as exc:
            raise CampaignError(str(exc)) from None
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


def _single(spec: CampaignSpec, base: Scenario, name: str) -> Scenario:
    """Variant ``name`` of ``base`` (``""``: ``base``), with the ``--set`` values meant for its
    prelude (``prelude.node.param``), which a variant may give it."""
    single = variant(base, name) if name else base
    for target, value in spec.overrides:
        if target.startswith(PRELUDE_PREFIX):
            single = apply_value(single, target, value, f"--set {target}")
    return single


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
        if not target.startswith(PRELUDE_PREFIX):  # those go to each variant's own prelude
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
    if spec.sampling == "grid" and spec.samples and not spec.sensitivity:
        raise CampaignError("--samples is for --sampling sobol or --sensitivity")
    targets = [s.target for s in spec.sweeps]
    if len(set(targets)) != len(targets):
        raise CampaignError(f"--sweep: a parameter is swept twice ({targets})")
    variant_names = list(spec.variants or base.variants) or [""]
    singles = {name: _single(spec, base, name) for name in variant_names}
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
        _check_dispersions(spec, base, name, single)
        _check_nodes(single, name)
        if spec.engine == "core":
            check_core_engine(single)
    draws = _draws(spec, base)
    runs: list[PlannedRun] = []
    design: dict[str, list[str]] = {}
    seen: set[str] = set()
    for point in _points(spec):
        point = _round_for_int_params(base, point)
        swept = {}
        for name, single in singles.items():
            swept[name] = single
            for target, value in point.items():
                swept[name] = apply_value(swept[name], target, value, f"--sweep {target}")
        # seed by seed, every variant of a seed together: a campaign stopped halfway has
        # the same seeds in each variant (and --resume carries on in that order)
        for seed, drawn in draws:
            values = {**point, **drawn}
            for name, scenario in swept.items():
                rid = run_id(base.name, name, seed, values)
                if spec.sensitivity:  # a design may hold a row twice (a listed value drawn again): one run
                    design.setdefault(name, []).append(rid)
                    if rid in seen:
                        continue
                    seen.add(rid)
                for target, value in drawn.items():
                    scenario = apply_value(scenario, target, value, f"dispersion {target}")
                seeded = dataclasses.replace(scenario, seed=seed)
                runs.append(PlannedRun(rid, name, seed, dict(values), seeded))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):
        raise CampaignError("two runs of the campaign are the same run (repeated sweep values?)")
    return CampaignPlan(spec, base, tuple(runs), fingerprint(spec, base), design)


def _check_dispersions(spec: CampaignSpec, base: Scenario, name: str, single: Scenario) -> None:
    """Refuse, before any run: a dispersed parameter also swept, set or set by the variant;
    a distribution whose support reaches values the node refuses; a sensitivity design
    that cannot be made."""
    fixed = {t.split("[")[0] for t, _ in spec.overrides} | {s.target.split("[")[0] for s in spec.sweeps}
    for target, dist in spec.dispersions:
        if target.split("[")[0] in fixed or target in fixed:
            raise CampaignError(f"dispersion {target}: the parameter is also swept or set (--sweep/--set)")
        if name and target.split("[")[0] in base.variants[name]:
            raise CampaignError(f"dispersion {target}: variant {name!r} sets it too")
        for value in dist.probe():
            apply_value(single, target, value, f"dispersion {target} = {dist.to_text()}: its support reaches "
                                               f"{value!r}, a value the node refuses")
    if len({t for t, _ in spec.dispersions}) != len(spec.dispersions):
        raise CampaignError("dispersions: a parameter is given twice")
    try:
        sensitivity_design.check_campaign(spec.sensitivity, spec.samples, len(spec.dispersions), len(spec.sweeps),
                                          len(spec.seeds))
    except sensitivity_design.SensitivityError as exc:
        raise CampaignError(str(exc)) from None


def _draws(spec: CampaignSpec, base: Scenario) -> list[tuple[int, dict[str, Any]]]:
    """(seed, dispersed values) of each draw (:func:`.dispersion.draws`), integer parameters' rounded."""
    try:
        rows = draws(spec.dispersions, spec.dispersion_sampling, spec.seeds, spec.sensitivity, spec.samples,
                     spec.sample_seed)
    except DispersionError as exc:
        raise CampaignError(str(exc)) from None
    return [(seed, _round_for_int_params(base, values)) for seed, values in rows]


def fingerprint(spec: CampaignSpec, base: Scenario) -> dict[str, Any]:
    """What, besides (variant, seed, values), shapes every run: a resumed campaign must match."""
    return {"scenario": base.name, "scenario_sha256": hashlib.sha256(base.to_yaml().encode()).hexdigest()[:16],
            "duration_s": base.duration_s, "mode": spec.mode if spec.engine == "graph" else None,
            "engine": spec.engine, "set": {k: v for k, v in spec.overrides}, **spec.review_dict()}
