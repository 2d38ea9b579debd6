"""Dispersions: a node parameter's uncertainty as a stated distribution, and how runs draw it.

A dispersion is given as text or as a YAML mapping, in the parameter's own units::

    normal(100, 30)                  {dist: normal, mean: 100, std: 30}
    truncnormal(100, 30, 0, 200)     {dist: truncnormal, mean: 100, std: 30, low: 0, high: 200}
    uniform(50, 150)                 {dist: uniform, low: 50, high: 150}
    choice(rate: 3, hold: 1)         {dist: choice, values: [rate, hold], weights: [3, 1]}

Every run's values come from one point u of the unit hypercube (one coordinate per
dispersed parameter) through each distribution's inverse CDF (:meth:`Distribution.ppf`).
The points are ``random`` (numpy's seeded generator), ``lhs`` (Latin hypercube) or
``sobol`` (scrambled Sobol, a power of 2 of them), all from ``scipy.stats.qmc``, seeded.
The same unit points drive the sensitivity designs (:mod:`.sensitivity`).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

from . import sensitivity

DISTRIBUTIONS = ("normal", "truncnormal", "uniform", "choice")
SAMPLINGS = ("random", "lhs", "sobol")
#: The unit points are kept this far inside (0, 1): a normal's inverse CDF is finite there (±7.9 σ).
EDGE = 1e-15
#: A truncated normal must keep at least this much of the normal's probability.
MIN_MASS = 1e-9
_CALL = re.compile(r"^\s*([a-z_]+)\s*\((.*)\)\s*$", re.S)


class DispersionError(ValueError):
    """A dispersion is malformed; the message names the parameter and what is wrong."""


@dataclass(frozen=True)
class Distribution:
    """One parameter's distribution: ``kind`` (:data:`DISTRIBUTIONS`) and its numbers; a
    ``choice`` has ``values`` and their ``weights`` (normalised)."""

    kind: str
    mean: float = 0.0
    std: float = 1.0
    low: float = -math.inf
    high: float = math.inf
    values: tuple[Any, ...] = ()
    weights: tuple[float, ...] = ()

    def ppf(self, u: np.ndarray) -> list[Any]:
        """The values at unit points ``u`` (the inverse CDF)."""
        from scipy import stats

        u = np.clip(np.asarray(u, float), EDGE, 1.0 - EDGE)
        if self.kind == "normal":
            return [float(v) for v in stats.norm.ppf(u, self.mean, self.std)]
        if self.kind == "truncnormal":
            a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
            return [float(v) for v in np.clip(stats.truncnorm.ppf(u, a, b, self.mean, self.std), self.low, self.high)]
        if self.kind == "uniform":
            return [float(v) for v in self.low + u * (self.high - self.low)]
        edges = np.cumsum(self.weights)
        return [self.values[min(int(i), len(self.values) - 1)] for i in np.searchsorted(edges, u, side="right")]

    def probe(self) -> list[Any]:
        """Values a node must accept for every draw to be valid: the support's ends (±8 σ of a
        normal) and every listed value."""
        if self.kind == "choice":
            return list(self.values)
        if self.kind == "normal":
            return [self.mean - 8 * self.std, self.mean, self.mean + 8 * self.std]
        return [self.low, self.high]

    def to_text(self) -> str:
        if self.kind == "normal":
            return f"normal({self.mean:g}, {self.std:g})"
        if self.kind == "truncnormal":
            return f"truncnormal({self.mean:g}, {self.std:g}, {self.low:g}, {self.high:g})"
        if self.kind == "uniform":
            return f"uniform({self.low:g}, {self.high:g})"
        return "choice(" + ", ".join(f"{v}: {w:g}" for v, w in zip(self.values, self.weights)) + ")"


def _finite(value: Any, what: str, where: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise DispersionError(f"{where}: {what} {value!r} is not a number") from None
    if isinstance(value, bool) or not math.isfinite(number):
        raise DispersionError(f"{where}: {what} {value!r} is not a finite number")
    return number


def _from_text(text: str, where: str) -> dict[str, Any]:
    match = _CALL.match(text)
    if not match:
        raise DispersionError(f"{where}: expected a distribution like normal(mean, std), got {text!r}")
    kind, inner = match.group(1), match.group(2)
    args = [a.strip() for a in inner.split(",")] if inner.strip() else []
    if kind == "choice":
        pairs = [a.partition(":") for a in args]
        return {"dist": kind, "values": [yaml.safe_load(v) for v, _, _ in pairs],
                "weights": [w.strip() if sep else 1.0 for _, sep, w in pairs]}
    names = {"normal": ("mean", "std"), "truncnormal": ("mean", "std", "low", "high"),
             "uniform": ("low", "high")}.get(kind)
    if names is None:
        raise DispersionError(f"{where}: unknown distribution {kind!r}; known: {', '.join(DISTRIBUTIONS)}")
    if len(args) != len(names):
        raise DispersionError(f"{where}: {kind} takes {len(names)} numbers ({', '.join(names)}), got {len(args)}")
    return {"dist": kind, **dict(zip(names, args))}


def parse_distribution(spec: Any, where: str) -> Distribution:
    """A :class:`Distribution` from text or a mapping (module docstring); raises
    :class:`DispersionError` naming ``where`` (the parameter) and the fault."""
    data = _from_text(spec, where) if isinstance(spec, str) else spec
    if not isinstance(data, dict) or "dist" not in data:
        raise DispersionError(f"{where}: expected normal(mean, std), ... or a mapping with 'dist', got {spec!r}")
    kind = data["dist"]
    if kind not in DISTRIBUTIONS:
        raise DispersionError(f"{where}: unknown distribution {kind!r}; known: {', '.join(DISTRIBUTIONS)}")
    allowed = {"normal": {"mean", "std"}, "truncnormal": {"mean", "std", "low", "high"}, "uniform": {"low", "high"},
               "choice": {"values", "weights"}}[kind]
    given = set(data) - {"dist"}
    if given - allowed or (kind != "choice" and given != allowed) or (kind == "choice" and "values" not in given):
        raise DispersionError(f"{where}: {kind} takes {sorted(allowed)}, got {sorted(given)}")
    if kind == "choice":
        return _choice(data, where)
    num = {k: _finite(v, k, where) for k, v in data.items() if k != "dist"}
    if "std" in num and not num["std"] > 0:
        raise DispersionError(f"{where}: {kind} needs std > 0, got {num['std']:g}")
    if "low" in num and not num["low"] < num["high"]:
        raise DispersionError(f"{where}: {kind} needs low < high, got [{num['low']:g}, {num['high']:g}]")
    if kind == "truncnormal":
        from scipy import stats

        mass = stats.norm.cdf(num["high"], num["mean"], num["std"]) - stats.norm.cdf(num["low"], num["mean"], num["std"])
        if not mass > MIN_MASS:
            raise DispersionError(f"{where}: truncnormal bounds [{num['low']:g}, {num['high']:g}] lie outside the "
                                  f"support of normal({num['mean']:g}, {num['std']:g}) (probability {mass:.2g} "
                                  f"between them)")
    return Distribution(kind, **num)


def _choice(data: dict[str, Any], where: str) -> Distribution:
    values = data["values"]
    if not isinstance(values, list) or not values:
        raise DispersionError(f"{where}: choice needs a non-empty list of values")
    weights = data.get("weights") or [1.0] * len(values)
    if not isinstance(weights, list) or len(weights) != len(values):
        raise DispersionError(f"{where}: choice needs one weight per value ({len(values)}), got {weights!r}")
    w = np.array([_finite(v, "weight", where) for v in weights])
    if np.any(w < 0) or not w.sum() > 0:
        raise DispersionError(f"{where}: choice weights must be >= 0 with a positive sum, got {weights!r}")
    return Distribution("choice", values=tuple(values), weights=tuple(float(v) for v in w / w.sum()))


def unit_points(method: str, n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points of the ``d``-dimensional unit hypercube by ``method`` (:data:`SAMPLINGS`), seeded."""
    from scipy.stats import qmc

    if method == "random":
        return np.random.default_rng(seed).random((n, d))
    if method == "lhs":
        return qmc.LatinHypercube(d=d, seed=seed).random(n)
    if method == "sobol":
        if n < 1 or n & (n - 1):
            raise DispersionError(f"dispersion_sampling sobol needs a power of 2 of runs (balance), got {n}")
        return qmc.Sobol(d=d, scramble=True, seed=seed).random_base2(int(math.log2(n)))
    raise DispersionError(f"dispersion_sampling must be one of {SAMPLINGS}, got {method!r}")


_TARGET = re.compile(r"^[A-Za-z_]\w*\.[A-Za-z_]\w*(\[\d+\])?$")


def parse_dispersions(data: Any, where: str) -> tuple[tuple[str, Distribution], ...]:
    """A campaign's ``dispersions:`` mapping, node.param (or node.param[i]) -> distribution."""
    if data is None:
        return ()
    if not isinstance(data, dict):
        raise DispersionError(f"{where}: 'dispersions' must map node.param to a distribution")
    parsed = []
    for target, dist in data.items():
        if not _TARGET.match(str(target)):
            raise DispersionError(f"dispersion {target}: expected node.param or node.param[i]")
        parsed.append((str(target), parse_distribution(dist, f"dispersion {target}")))
    return tuple(parsed)


def parse_review(data: dict[str, Any], where: str) -> dict[str, Any]:
    """The ``dispersions``, ``dispersion_sampling`` and ``sensitivity`` of a campaign mapping."""
    kw: dict[str, Any] = {"dispersions": parse_dispersions(data.get("dispersions"), where)}
    if "dispersion_sampling" in data:
        if data["dispersion_sampling"] not in SAMPLINGS:
            raise DispersionError(f"{where}: dispersion_sampling must be one of {SAMPLINGS}, "
                                  f"got {data['dispersion_sampling']!r}")
        kw["dispersion_sampling"] = data["dispersion_sampling"]
    if data.get("sensitivity"):
        if data["sensitivity"] not in sensitivity.METHODS:
            raise DispersionError(f"{where}: sensitivity must be one of {sensitivity.METHODS}, "
                                  f"got {data['sensitivity']!r}")
        kw["sensitivity"] = data["sensitivity"]
    return kw


def draws(dispersions: tuple[tuple[str, Distribution], ...], sampling: str, seeds: tuple[int, ...], method: str,
          samples: int, sample_seed: int) -> list[tuple[int, dict[str, Any]]]:
    """(seed, {target: value}) of each draw: one per seed (the n-th seed the n-th point of the
    ``sampling``), or one per row of the sensitivity design of ``method`` (its seed factor's seed)."""
    targets = [t for t, _ in dispersions]
    if method:
        rows = sensitivity.design(method, samples, targets, sample_seed)
        unit = sensitivity.unit_values(method, rows)
        run_seeds = sensitivity.seeds_of(unit[:, -1])
    elif dispersions:
        unit = unit_points(sampling, len(seeds), len(targets), sample_seed)
        run_seeds = list(seeds)
    else:
        return [(seed, {}) for seed in seeds]
    columns = [dist.ppf(unit[:, j]) for j, (_, dist) in enumerate(dispersions)]
    return [(seed, {t: columns[j][i] for j, t in enumerate(targets)}) for i, seed in enumerate(run_seeds)]
