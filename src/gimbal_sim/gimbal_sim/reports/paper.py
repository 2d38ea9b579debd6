"""The papers' figures beside the measured ones, for the pages (:mod:`gimbal_sim.page`).

:data:`PAPER_FIGURES` maps a metric-name pattern to the figure a paper states for it. Paper 1's
LOS drift depends on the run, not only on the metric: Fig. 4 (controller on, biases not
estimated) drifts "3-4 degrees in 2 minutes" in azimuth and elevation, Fig. 5 (the estimated
biases fed back) "negligible" (docs/spec.md §3.1). Which one a ``sighting`` run is, is its
``los_rate_controller``'s ``feedback`` parameter, read from the scenario: the run's, each
variant's (a comparison's ``cases.<variant>.*``), or each campaign group's variant.
"""
from __future__ import annotations

import json
import re
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

import yaml

from ..graph.scenario import ScenarioError, apply_set, load, validate, variant
from .alignment import LIMITS as ALIGNMENT_LIMITS
from .encoder_fusion import PAPER_IMPROVEMENT
from .platform_servo import LIMITS_ARCSEC as SERVO_LIMITS_ARCSEC

#: Paper 4: the probability of a fix inside the FDOP x sigma circle for a circular error (1 - 1/e).
PAPER4_INSIDE_FDOP = 0.63
#: Paper 5: the flexure measurement accuracy in full-scale experiments on ships [arcsec].
PAPER5_ACCURACY_ARCSEC = 20.0
#: Metric-name pattern -> the paper's figure, whatever the run.
PAPER_FIGURES = (
    (r"(^|\.)fusion_improvement$", f"≥ {PAPER_IMPROVEMENT:g}× (paper 2)"),
    (r"(^|\.)tilt_error_arcsec\.(east|north)$", f"|·| ≤ {ALIGNMENT_LIMITS['tilt_arcsec']:g} arcsec (paper 3 Table 2)"),
    (r"(^|\.)azimuth_error_arcmin$", f"|·| ≤ {ALIGNMENT_LIMITS['azimuth_arcmin']:g} arcmin (paper 3 Table 2)"),
    (r"(^|\.)north_drift_error_deg_h$", f"|·| ≤ {ALIGNMENT_LIMITS['north_drift_deg_h']:g} deg/h (paper 3 Table 2)"),
    *((rf"control_error_arcsec\.(sensed|truth_drift_removed)\.{kind}\.max$",
       f"< {paper:g} arcsec (paper 3 §4.1)") for kind, (paper, _) in SERVO_LIMITS_ARCSEC.items()),
    # paper 4, after eq. 38: "If ... two-dimensional error distribution is close to being circular,
    # the probability is about 0.63" (1 - 1/e) that a fix lies inside the FDOP x sigma circle
    (r"(^|\.)inside_fdop_circle$", f"≈ {PAPER4_INSIDE_FDOP:g} of fixes, circular error (paper 4 after eq. 38)"),
    # paper 5, abstract and conclusion: "the proposed method can reach an accuracy of 20″"
    # (full-scale trials on ships): the flexure's error, total and quasi-static, per axis
    (r"(^|\.)(total|qs)_rms_arcsec(\.\d+)?$", f"≈ {PAPER5_ACCURACY_ARCSEC:g} arcsec, ship trials (paper 5 abstract)"),
)
#: Paper 1's LOS drift at the end of a 120 s run, without and with the bias feedback.
PAPER1_DRIFT = {False: "|·| 3–4 deg in 120 s (paper 1 Fig. 4, biases not estimated)",
                True: "negligible (paper 1 Fig. 5, estimated biases fed back)"}
_DRIFT = re.compile(r"(^|\.)final_drift_deg\.(azimuth|elevation)$")
_CASE = re.compile(r"^cases\.([^.]+)\.")
PaperLookup = Callable[[str], "str | None"]


def paper_figure(name: str) -> str | None:
    """The paper's figure for the metric ``name`` (dotted) that holds whatever the run."""
    return next((text for pattern, text in PAPER_FIGURES if re.search(pattern, name)), None)


def _feedback(nodes: dict[str, Any]) -> bool:
    """Whether the LOS controller of a scenario's ``nodes`` feeds the estimated biases back."""
    params = next((spec.get("params") or {} for name, spec in nodes.items()
                   if (spec.get("executable") or name) == "los_rate_controller"), {})
    return bool(params.get("feedback", False))


def _sighting(data: dict[str, Any]) -> bool:
    return data.get("report") == "sighting"


def run_paper_lookup(scenario_file: Path) -> PaperLookup:
    """The lookup of a run's page: the general figures, and paper 1's drift of this run."""
    data = _read(scenario_file)
    drift = PAPER1_DRIFT[_feedback(data.get("nodes") or {})] if _sighting(data) else None
    return lambda name: (drift if drift and _DRIFT.search(name) else paper_figure(name))


def comparison_paper_lookup(scenario_file: Path) -> PaperLookup:
    """The lookup of a comparison's page: paper 1's drift of each variant's case."""
    data = _read(scenario_file)
    drifts = {}
    if _sighting(data):
        try:
            base = validate(data, str(scenario_file))
            drifts = {v: PAPER1_DRIFT[_feedback(variant(base, v).nodes)] for v in base.variants}
        except ScenarioError:
            drifts = {}

    def lookup(name: str) -> str | None:
        case = _CASE.match(name)
        if case and case.group(1) in drifts and _DRIFT.search(name):
            return drifts[case.group(1)]
        return paper_figure(name)
    return lookup


@lru_cache(maxsize=8)
def _campaign_drifts(campaign_dir: Path) -> dict[str | None, str]:
    """Paper 1's drift figure per variant of a ``sighting`` campaign (None: no variant)."""
    spec = (_read(campaign_dir / "campaign.yaml").get("campaign") or {})
    try:
        scenario = load(str(spec.get("scenario", "")))
        if scenario.report != "sighting":
            return {}
        singles = {None: scenario, **{v: variant(scenario, v) for v in scenario.variants}}
        for target, value in (spec.get("set") or {}).items():  # the campaign's --set, in every run
            singles = {v: apply_set(s, f"{target}={json.dumps(value)}") for v, s in singles.items()}
    except (ScenarioError, OSError):
        return {}
    return {v: PAPER1_DRIFT[_feedback(s.nodes)] for v, s in singles.items()}


def campaign_paper_figure(campaign_dir: Path, variant_name: str | None, name: str) -> str | None:
    """The paper's figure of the metric ``name`` in the campaign's group of ``variant_name``."""
    drifts = _campaign_drifts(Path(campaign_dir).resolve())
    if _DRIFT.search(name) and (variant_name or None) in drifts:
        return drifts[variant_name or None]
    return paper_figure(name)


def _read(path: Path) -> dict[str, Any]:
    try:
        return yaml.safe_load(Path(path).read_text()) or {}
    except (OSError, yaml.YAMLError):
        return {}
