"""Windowed normalised innovation squared (NIS): a filter's consistency check without truth.

For a consistent filter the innovation y_k (m,) with covariance S_k has
NIS_k = y_kᵀ S_k⁻¹ y_k ~ χ²(m), independent from update to update (the innovation sequence
is white). The sum of the last n of them is χ²(n m), so their mean lies within

    [χ²⁻¹(α/2; n m) / n,  χ²⁻¹(1 − α/2; n m) / n]

with probability 1 − α (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to
Tracking and Navigation*, §5.4). NEES needs the true state; NIS needs only what the filter
computed, so it is what a user has on real data. :class:`NisWindow` keeps the last
``window`` NIS values and gives their mean, the two-sided 95 % bounds (``scipy.stats.chi2``)
and a verdict:

* ``consistent``: the mean is within the bounds;
* ``overconfident``: above the upper bound (innovations larger than the filter predicts:
  too little process or measurement noise, or a fault);
* ``conservative``: below the lower bound (the filter's noise is larger than the data's);
* ``insufficient``: fewer than ``min_samples`` values so far.

Gated innovations are included: they are part of the sequence the filter saw, and leaving
them out would bias the statistic low. Alignment "innovations" (none computed) are not fed.
"""
from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

from scipy.stats import chi2


class NisVerdict(NamedTuple):
    """Mean NIS over the window and its bounds (per update, i.e. for one χ²(m) sample)."""

    mean: float
    lower: float
    upper: float
    samples: int
    verdict: str


class NisWindow:
    """The last ``window`` NIS values of an ``dof``-dimensional innovation (module docstring)."""

    def __init__(self, dof: int, window: int = 100, probability: float = 0.95, min_samples: int = 10) -> None:
        if int(dof) < 1:
            raise ValueError(f"dof must be >= 1, got {dof}")
        if int(window) < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        if not 0.0 < probability < 1.0:
            raise ValueError(f"probability must be in (0, 1), got {probability}")
        self.dof = int(dof)
        self.window = int(window)
        self.probability = float(probability)
        self.min_samples = max(1, min(int(min_samples), self.window))
        self._values: deque[float] = deque(maxlen=self.window)
        self._bounds: dict[int, tuple[float, float]] = {}
        self.rejected_nonfinite = 0

    def add(self, nis: float) -> None:
        """One update's NIS (non-finite values are counted, not kept)."""
        nis = float(nis)
        if not math.isfinite(nis) or nis < 0.0:
            self.rejected_nonfinite += 1
            return
        self._values.append(nis)

    def bounds(self, n: int) -> tuple[float, float]:
        """Two-sided bounds of the mean of ``n`` NIS values at :attr:`probability`."""
        b = self._bounds.get(n)
        if b is None:
            a = 0.5 * (1.0 - self.probability)
            k = n * self.dof
            b = (float(chi2.ppf(a, k)) / n, float(chi2.ppf(1.0 - a, k)) / n)
            self._bounds[n] = b
        return b

    def verdict(self) -> NisVerdict:
        """Mean, bounds and verdict of the current window."""
        n = len(self._values)
        if n == 0:
            return NisVerdict(math.nan, math.nan, math.nan, 0, "insufficient")
        # summed per call (window-sized, once per diagnostics period): no running-sum drift
        mean = math.fsum(self._values) / n
        lo, hi = self.bounds(n)
        if n < self.min_samples:
            word = "insufficient"
        elif mean > hi:
            word = "overconfident"
        elif mean < lo:
            word = "conservative"
        else:
            word = "consistent"
        return NisVerdict(mean, lo, hi, n, word)

    def as_dict(self) -> dict[str, float | int | str]:
        """The verdict as diagnostics key/values (``nis_*``)."""
        v = self.verdict()
        return {"nis_mean": round(v.mean, 4), "nis_lower_95": round(v.lower, 4), "nis_upper_95": round(v.upper, 4),
                "nis_dof": self.dof, "nis_window": v.samples, "nis_verdict": v.verdict}
