"""Distribution-free statistics of a campaign's runs: order statistics and binomial intervals.

A requirement "metric ≤ bound in a fraction p of the cases, at confidence c" is judged with
Wilks' order statistics (NASA/TP-2010-216447, Hanson & Beard), not a normal fit: of n runs
sorted x_(1) ≤ … ≤ x_(n), the k-th is an upper confidence bound of the p-quantile q_p at
level c when P(x_(k) ≥ q_p) = P(B(n, p) ≤ k − 1) ≥ c, B binomial. The smallest such k gives
the tightest bound; the requirement is met when x_(k) ≤ bound, which is the same as at most
n − k runs exceeding the bound. With zero exceedances allowed (k = n, the largest run),
n ≥ ln(1 − c) / ln p runs are needed: 22 for p = c = 0.9, 230 for p = 0.99, c = 0.9.

The two-sided interval of a quantile (the median's for the CEP50) takes the order
statistics whose binomial tails are each at most (1 − confidence) / 2; a pass fraction
carries its exact (Clopper–Pearson) binomial interval.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from scipy import stats


def upper_bound_rank(n: int, p: float, c: float) -> int | None:
    """The smallest rank k (1-based) whose order statistic x_(k) of ``n`` runs bounds the
    ``p``-quantile from above at confidence ``c`` (module docstring); None: too few runs."""
    if n < 1:
        return None
    ranks = np.arange(1, n + 1)
    ok = ranks[stats.binom.cdf(ranks - 1, n, p) >= c]
    return int(ok[0]) if ok.size else None


def wilks_runs(p: float, c: float, failures: int = 0) -> int:
    """The fewest runs that demonstrate the ``p``-quantile below a bound at confidence ``c``
    with ``failures`` runs above it (0: the largest run is the bound)."""
    n = max(failures + 1, math.ceil(math.log1p(-c) / math.log(p)) - 1)  # the closed form, less rounding
    while (rank := upper_bound_rank(n, p, c)) is None or n - rank < failures:
        n += 1
    return n


def quantile_interval(values: Sequence[float], q: float, confidence: float = 0.95) -> tuple[float, float, float]:
    """(sample q-quantile, low, high): the distribution-free interval [x_(l), x_(u)] of the
    true ``q``-quantile, l the largest rank with P(B(n, q) ≤ l − 1) ≤ α/2 and u the smallest
    with P(B(n, q) ≥ u) ≤ α/2, α = 1 − ``confidence``; ±inf where no rank qualifies. For
    q = ½ it is the symmetric interval [x_(j), x_(n+1−j)] of the median."""
    x = np.sort(np.asarray(values, dtype=float))
    n = len(x)
    if n == 0:
        return math.nan, -math.inf, math.inf
    alpha = (1.0 - confidence) / 2.0
    ranks = np.arange(1, n + 1)
    low_ok = ranks[stats.binom.cdf(ranks - 1, n, q) <= alpha]
    high_ok = ranks[stats.binom.sf(ranks - 1, n, q) <= alpha]
    estimate = float(np.quantile(x, q))
    lo = float(x[low_ok[-1] - 1]) if low_ok.size else -math.inf
    hi = float(x[high_ok[0] - 1]) if high_ok.size else math.inf
    return estimate, lo, hi


def clopper_pearson(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The exact binomial interval of a fraction ``successes`` / ``n``."""
    if n == 0:
        return 0.0, 1.0
    alpha = 1.0 - confidence
    lo = 0.0 if successes == 0 else float(stats.beta.ppf(alpha / 2, successes, n - successes + 1))
    hi = 1.0 if successes == n else float(stats.beta.ppf(1 - alpha / 2, successes + 1, n - successes))
    return lo, hi


class RequirementError(ValueError):
    """A requirement is malformed; the message names it and what is wrong."""


@dataclass(frozen=True)
class Requirement:
    """``metric`` (``|metric|`` when ``absolute``) ≤ ``bound`` (or ≥ with ``upper`` False) in a
    fraction ``p`` of the cases at confidence ``c``."""

    metric: str
    bound: float
    p: float
    c: float
    upper: bool = True
    absolute: bool = False

    @property
    def text(self) -> str:
        name = f"|{self.metric}|" if self.absolute else self.metric
        return f"{name} {'<=' if self.upper else '>='} {self.bound:g} in {self.p:.4g} of runs at {self.c:.4g} confidence"

    def to_dict(self) -> dict[str, Any]:
        return {"metric": self.metric, ("max" if self.upper else "min"): self.bound, "p": self.p, "c": self.c,
                **({"abs": True} if self.absolute else {})}


def verdict(req: Requirement, values: Sequence[float | None]) -> dict[str, Any]:
    """The requirement's verdict on the runs' ``values`` (None/NaN count as exceeding it):
    ``met``, ``not met`` or ``too few runs``, the order statistic used, the exceedances and
    the pass fraction with its Clopper–Pearson interval at ``c``."""
    x = np.array([math.nan if v is None else float(v) for v in values], float)
    if req.absolute:
        x = np.abs(x)
    # a lower bound is an upper bound of the negated metric: one rule for both
    signed = np.where(np.isfinite(x), x if req.upper else -x, math.inf)
    bound = req.bound if req.upper else -req.bound
    n = int(signed.size)
    passed = int(np.sum(signed <= bound))
    rank = upper_bound_rank(n, req.p, req.c)
    lo, hi = clopper_pearson(passed, n, req.c)
    out: dict[str, Any] = {"requirement": req.text, **req.to_dict(), "runs": n, "passed": passed,
                           "exceeded": n - passed, "pass_fraction": passed / n if n else math.nan,
                           "pass_fraction_interval": [lo, hi], "runs_needed_zero_failures": wilks_runs(req.p, req.c)}
    if rank is None:
        out.update(verdict="too few runs", rank=None, order_statistic=None,
                   detail=f"too few runs: needs {out['runs_needed_zero_failures']} (with none exceeding "
                          f"{req.bound:g}), has {n}")
        return out
    stat = float(np.sort(signed)[rank - 1])
    value = stat if req.upper else -stat
    met = stat <= bound
    which = "the largest" if rank == n else f"the {_ordinal(n - rank + 1)} largest"
    if not req.upper:
        which = which.replace("largest", "smallest")
    out.update(verdict="met" if met else "not met", rank=rank, order_statistic=value,
               detail=f"{which} of {n} runs (order statistic {rank if req.upper else n - rank + 1} of {n}) = "
                      f"{value:.6g} {'<=' if req.upper else '>='} {req.bound:g}" if met else
                      f"{which} of {n} runs = {value:.6g}: {n - passed} run(s) beyond {req.bound:g}, at most "
                      f"{n - rank} allowed")
    out["quantile"] = f"upper {req.c:.4g}-confidence bound of the {req.p:.4g}-quantile" if req.upper else \
        f"lower {req.c:.4g}-confidence bound of the {1 - req.p:.4g}-quantile"
    return out


def _ordinal(k: int) -> str:
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


_REQUIREMENT = re.compile(r"^\s*(\|?)\s*([A-Za-z_][\w.\[\]-]*)\s*\1\s*(<=|>=)\s*([^,\s]+)\s*,\s*p\s*=\s*([^,\s]+)\s*,"
                          r"\s*c\s*=\s*([^,\s]+)\s*$")


def parse_requirement(item: Any, where: str) -> Requirement:
    """A requirement from a mapping ``{metric, max | min, p, c, abs}`` or the text
    ``METRIC<=BOUND,p=P,c=C`` (``|METRIC|`` for its magnitude, ``>=`` for a lower bound)."""
    if isinstance(item, str):
        match = _REQUIREMENT.match(item)
        if not match:
            raise RequirementError(f"{where}: requirement {item!r}: expected METRIC<=BOUND,p=P,c=C (or |METRIC|, >=)")
        bar, metric, op, bound, p, c = match.groups()
        item = {"metric": metric, ("max" if op == "<=" else "min"): bound, "p": p, "c": c, "abs": bool(bar)}
    if not isinstance(item, dict) or "metric" not in item or len({"max", "min"} & set(item)) != 1 \
            or not {"p", "c"} <= set(item) or set(item) - {"metric", "max", "min", "p", "c", "abs"}:
        raise RequirementError(f"{where}: requirement {item!r}: expected metric, max or min, p, c (and abs)")
    numbers = {}
    for key in ({"max", "min"} & set(item)) | {"p", "c"}:
        try:
            numbers[key] = float(item[key])
        except (TypeError, ValueError):
            raise RequirementError(f"{where}: requirement on {item['metric']}: {key} {item[key]!r} is not a number") from None
        if isinstance(item[key], bool) or not math.isfinite(numbers[key]):
            raise RequirementError(f"{where}: requirement on {item['metric']}: {key} must be a finite number")
    for key in ("p", "c"):
        if not 0.0 < numbers[key] < 1.0:
            raise RequirementError(f"{where}: requirement on {item['metric']}: {key} must lie in (0, 1), got "
                                f"{numbers[key]:g}")
    upper = "max" in item
    return Requirement(str(item["metric"]), numbers["max" if upper else "min"], numbers["p"], numbers["c"], upper,
                       bool(item.get("abs", False)))


def parse_requirements(data: Any, where: str) -> tuple[Requirement, ...]:
    """A campaign's ``requirements:`` list (each item as :func:`parse_requirement` reads it)."""
    if data is None:
        return ()
    if not isinstance(data, list):
        raise RequirementError(f"{where}: 'requirements' must be a list")
    return tuple(parse_requirement(item, where) for item in data)
