"""Variance-based sensitivity of a campaign's metrics to its dispersed parameters (SALib).

``sobol``: Saltelli's design (``SALib.sample.sobol``, scrambled Sobol points, first-order and
total indices, no second order) of N·(D + 2) runs, N a power of 2, analysed by
``SALib.analyze.sobol`` with bootstrap 95 % intervals. ``morris``: N Morris trajectories
of D + 1 runs on a 4-level grid (``SALib.sample.morris``), elementary effects by
``SALib.analyze.morris`` (μ*, its bootstrap interval, σ): a cheap screen of many parameters.

Both designs are made in the unit hypercube and mapped through each parameter's
distribution (:meth:`~.dispersion.Distribution.ppf`), so any distribution (a weighted list
too) can be dispersed; Morris's grid levels are the centres of 4 equal-probability bins
(1/8, 3/8, 5/8, 7/8), finite for a normal, and its effects are per unit of probability
(a change of the metric per change of the parameter's CDF). The
run's seed is one more factor of the design (:data:`SEED_FACTOR`), mapped to an integer seed:
the share of a metric's variance that is the noise of the run shows as its index.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

METHODS = ("sobol", "morris")
SEED_FACTOR = "seed (noise)"
MORRIS_LEVELS = 4
#: Seeds drawn from the seed factor lie in [0, SEED_SPAN) (the sensor nodes take < 2^31).
SEED_SPAN = 2**31 - 1
BOOTSTRAP = 500


class SensitivityError(ValueError):
    """A sensitivity design cannot be made as asked."""


def _problem(names: Sequence[str]) -> dict[str, Any]:
    return {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}


def runs_of(method: str, samples: int, dispersed: int) -> int:
    """The design's rows for ``samples`` (N) over ``dispersed`` parameters and the seed."""
    d = dispersed + 1
    return samples * (d + 2) if method == "sobol" else samples * (d + 1)


def check(method: str, samples: int) -> None:
    """Refuse a design that cannot be made: an unknown method, a Saltelli N that is not a
    power of 2, fewer than 2 Morris trajectories."""
    if method not in METHODS:
        raise SensitivityError(f"--sensitivity must be one of {METHODS}, got {method!r}")
    if method == "sobol" and (samples < 2 or samples & (samples - 1)):
        raise SensitivityError(f"--sensitivity sobol: --samples (the Saltelli design's N) must be a power of 2 "
                               f">= 2, got {samples}")
    if method == "morris" and samples < 2:
        raise SensitivityError(f"--sensitivity morris: --samples (trajectories) must be >= 2, got {samples}")


def check_campaign(method: str, samples: int, dispersed: int, swept: int, seeds: int) -> None:
    """Refuse a sensitivity campaign that cannot be made (nothing when ``method`` is "")."""
    if not method:
        return
    if not dispersed:
        raise SensitivityError(f"--sensitivity {method}: needs dispersions (the parameters to rank)")
    if swept:
        raise SensitivityError(f"--sensitivity {method}: drop the sweeps (the design is its own)")
    if seeds > 1:
        raise SensitivityError(f"--sensitivity {method}: the seed is a factor of the design; drop --seeds")
    check(method, samples)


def design(method: str, samples: int, names: Sequence[str], seed: int) -> np.ndarray:
    """The design in the unit hypercube, one column per name of ``names`` and the seed factor
    last: (rows, len(names) + 1). Morris's rows are its grid (levels 0, 1/3, 2/3, 1)."""
    from SALib.sample import morris, sobol

    check(method, samples)
    problem = _problem([*names, SEED_FACTOR])
    if method == "sobol":
        return sobol.sample(problem, samples, calc_second_order=False, scramble=True, seed=seed)
    return morris.sample(problem, samples, num_levels=MORRIS_LEVELS, seed=seed)


def unit_values(method: str, rows: np.ndarray) -> np.ndarray:
    """Where the design's rows sit in probability: Saltelli's as they are, Morris's grid
    levels at the centres of equal-probability bins (module docstring)."""
    if method == "morris":
        return (rows * (MORRIS_LEVELS - 1) + 0.5) / MORRIS_LEVELS
    return rows


def seeds_of(u: np.ndarray) -> list[int]:
    """The run seed of each unit value of the seed factor."""
    return [min(int(math.floor(float(v) * SEED_SPAN)), SEED_SPAN - 1) for v in u]


def analyze(method: str, names: Sequence[str], rows: np.ndarray, y: Sequence[float], seed: int) -> dict[str, Any]:
    """The indices of one metric ``y`` (one value per design row, in order) per factor (the
    names and the seed factor): Sobol ``S1``, ``ST`` with 95 % bootstrap half-widths, or
    Morris ``mu_star`` (with its half-width), ``mu``, ``sigma``."""
    from SALib.analyze import morris, sobol

    y = np.asarray(y, float)
    problem = _problem([*names, SEED_FACTOR])
    factors = problem["names"]
    if method == "sobol":
        res = sobol.analyze(problem, y, calc_second_order=False, num_resamples=BOOTSTRAP, conf_level=0.95,
                            seed=seed, print_to_console=False)
        return {"method": method, "factors": {f: {"S1": float(res["S1"][i]), "S1_conf": float(res["S1_conf"][i]),
                                                  "ST": float(res["ST"][i]), "ST_conf": float(res["ST_conf"][i])}
                                              for i, f in enumerate(factors)}}
    res = morris.analyze(problem, rows, y, num_levels=MORRIS_LEVELS, num_resamples=BOOTSTRAP, conf_level=0.95,
                         seed=seed, print_to_console=False)
    # SALib's effects are per unit of its grid [0, 1]: a grid step of 1/(L - 1) is 1/L of probability
    scale = MORRIS_LEVELS / (MORRIS_LEVELS - 1)
    return {"method": method, "factors": {f: {key: scale * float(res[key][i])
                                              for key in ("mu_star", "mu_star_conf", "mu", "sigma")}
                                          for i, f in enumerate(factors)}}
