"""Accuracy and CPU time of the two attitude-matching methods of paper 5 on the same LGU
samples: the original (eq. 1, :class:`.flexure_attitude_matching.AttitudeMatchingKf`) and
the simplified (eq. 5, :class:`.flexure_kf.FlexureKf`).

Pure: the caller supplies the runs (LGU pairs and the flexure truth at each stamp), e.g.
from the simulator. CPU time is ``time.process_time`` around each pair's two filter calls,
so it counts this process only, but a busy machine still slows it (caches, frequency).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import NamedTuple

import numpy as np

from . import kalman
from .flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from .flexure_kf import PHI_K, THETA_K, FlexureKf

_ARCSEC = np.pi / 180.0 / 3600.0


class LguRun(NamedTuple):
    """One run's LGU pairs: stamps ``t`` (n,) [s], increments ``dalpha1``, ``dalpha2``
    (n, 3) [rad] over ``dt`` (n,) [s], and the true flexure ``truth`` (n, 3) [rad] at each
    stamp."""

    t: np.ndarray
    dalpha1: np.ndarray
    dalpha2: np.ndarray
    dt: np.ndarray
    truth: np.ndarray


class MethodFigures(NamedTuple):
    """One method over all runs: ``rms_arcsec`` (3,) total-flexure RMS error (roll, pitch,
    yaw) over the epochs after convergence; ``nees_mean`` mean NEES of the flexure (3 dof)
    over those epochs; ``final_nees`` (runs,) the NEES at each run's last epoch;
    ``cpu_us_per_pair`` filter CPU time per LGU pair [µs]; ``pairs``, ``epochs`` counts."""

    rms_arcsec: np.ndarray
    nees_mean: float
    final_nees: np.ndarray
    cpu_us_per_pair: float
    pairs: int
    epochs: int


def flexure_covariance(kf: FlexureKf) -> np.ndarray:
    """Covariance (3, 3) of the total flexure Φ_k + θ_k of either filter (the original's
    first 12 states are laid out as the simplified one's)."""
    P = kf.covariance
    return P[PHI_K, PHI_K] + P[THETA_K, THETA_K] + P[PHI_K, THETA_K] + P[THETA_K, PHI_K]


def _run_method(make: Callable[[], FlexureKf], runs: list[LguRun], convergence_s: float) -> MethodFigures:
    clock = time.process_time
    cpu = 0.0
    pairs = 0
    sq = np.zeros(3)
    nees: list[float] = []
    final: list[float] = []
    for run in runs:
        kf = make()
        last = np.nan
        t0 = run.t[0]
        for k in range(run.t.size):
            c0 = clock()
            kf.on_lgu1(run.t[k], run.dalpha1[k], run.dt[k])
            est = kf.on_lgu2(run.t[k], run.dalpha2[k], run.dt[k])
            cpu += clock() - c0
            pairs += 1
            if est is None:
                continue
            err = est.flexure - run.truth[k]
            last = kalman.nees(err, flexure_covariance(kf))
            if est.t - t0 >= convergence_s:
                sq += err * err
                nees.append(last)
        final.append(last)
    n = len(nees)
    return MethodFigures(np.sqrt(sq / max(n, 1)) / _ARCSEC, float(np.mean(nees)) if n else float("nan"),
                         np.asarray(final), 1e6 * cpu / max(pairs, 1), pairs, n)


def compare_methods(runs: Iterable[LguRun], params: AttitudeMatchingParams | None = None,
                    convergence_s: float = 0.0) -> dict[str, MethodFigures]:
    """Run a fresh filter of each method over each run (the same samples for both; the
    simplified filter takes ``params``' shared fields) and score it against the truth after
    ``convergence_s`` [s] of each run. Returns ``{"original": MethodFigures,
    "simplified": MethodFigures}``."""
    runs = list(runs)
    original = AttitudeMatchingParams() if params is None else params
    simplified = original.simplified()
    return {"original": _run_method(lambda: AttitudeMatchingKf(original), runs, convergence_s),
            "simplified": _run_method(lambda: FlexureKf(simplified), runs, convergence_s)}
