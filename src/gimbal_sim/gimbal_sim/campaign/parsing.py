"""The campaign's words parsed from text: seeds (``1-20``, ``1,4,7-9``) and sweeps
(``a:b:n``, ``a:b``, lists), and the error every campaign check raises (:mod:`.spec` uses them)."""
from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

_TARGET = re.compile(r"^([A-Za-z_][\w]*)\.([A-Za-z_][\w]*)(?:\[(\d+)\])?$")
#: Seeds one campaign may list at all.
MAX_SEEDS = 1_000_000


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


def parse_assignments(items: list[str] | None, option: str) -> dict[str, str]:
    """``NODE.PARAM=VALUE`` items (``--set``, ``--sweep``, ``--disperse``) as target -> text."""
    out = {}
    for item in items or []:
        target, sep, value = item.partition("=")
        if not sep or not target.strip() or not value.strip():
            raise CampaignError(f"{option} {item!r}: expected NODE.PARAM=VALUE")
        out[target.strip()] = value.strip()
    return out


def parse_set(items: list[str] | None) -> dict[str, Any]:
    """``--set NODE.PARAM=VALUE`` items as target -> value (each value read as YAML)."""
    try:
        return {k: yaml.safe_load(v) for k, v in parse_assignments(items, "--set").items()}
    except yaml.YAMLError as exc:
        raise CampaignError(f"--set: value is not valid YAML: {exc}") from None
