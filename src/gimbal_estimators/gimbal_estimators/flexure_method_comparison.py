"""Accuracy and CPU time of the two attitude-matching methods of paper 5 on the same LGU
samples: the original (eq. 1, :class:`.flexure_attitude_matching.AttitudeMatchingKf`) and
the simplified (eq. 5, :class:`.flexure_kf.FlexureKf`).

Pure: the caller supplies the runs (LGU pairs and the flexure truth at each stamp), e.g.
from the simulator. CPU time is ``time.process_time`` around each pair's two filter calls,
so it counts this process only, but a busy machine still slows it (shared caches and
cores): report it with the machine's load, never assert it.
"""
from __future__ import annotations

import time
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from gimbal_kinematics.maths.units import ARCSEC

from gimbal_kinematics.maths import kalman
from .flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from .flexure_kf import PHI_K, THETA_K, FlexureKf


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


class _Score:
    """One method's running figures."""

    def __init__(self) -> None:
        self.cpu = 0.0
        self.sq = np.zeros(3)
        self.nees: list[float] = []
        self.final: list[float] = []

    def figures(self, pairs: int) -> MethodFigures:
        n = len(self.nees)
        return MethodFigures(np.sqrt(self.sq / max(n, 1)) / ARCSEC, float(np.mean(self.nees)) if n else float("nan"),
                             np.asarray(self.final), 1e6 * self.cpu / max(pairs, 1), pairs, n)


def _step(kf: FlexureKf, run: LguRun, k: int, score: _Score, convergence_s: float) -> float:
    """Feed pair ``k`` to ``kf``, add its CPU time to ``score`` and score its estimate;
    returns the estimate's NEES (nan when the pair ended no filter step)."""
    c0 = time.process_time()
    # a run's pairs come in stamp order, both units of a stamp together: nothing to pair or order
    lgu1 = kf.check_sample(run.t[k], run.dalpha1[k], run.dt[k])
    lgu2 = kf.check_sample(run.t[k], run.dalpha2[k], run.dt[k])
    est = None if lgu1 is None or lgu2 is None else kf.on_pair(lgu1[0], lgu1[1:], lgu2[1:])
    score.cpu += time.process_time() - c0
    if est is None:
        return float("nan")
    err = est.flexure - run.truth[k]
    d2 = kalman.nees(err, flexure_covariance(kf))
    if est.t - run.t[0] >= convergence_s:
        score.sq += err * err
        score.nees.append(d2)
    return d2


def compare_methods(runs: Iterable[LguRun], params: AttitudeMatchingParams | None = None,
                    convergence_s: float = 0.0) -> dict[str, MethodFigures]:
    """Run a fresh filter of each method over each run (the same samples for both; the
    simplified filter takes ``params``' shared fields) and score it against the truth after
    ``convergence_s`` [s] of each run. Returns ``{"original": MethodFigures,
    "simplified": MethodFigures}``.

    The two filters take each pair in turn, in alternating order, so that a change of the
    machine's load during the run weighs on both CPU figures alike.
    """
    original = AttitudeMatchingParams() if params is None else params
    simplified = original.simplified()
    scores = {"original": _Score(), "simplified": _Score()}
    pairs = 0
    for run in runs:
        filters = {"original": AttitudeMatchingKf(original), "simplified": FlexureKf(simplified)}
        last = dict.fromkeys(filters, float("nan"))
        for k in range(run.t.size):
            for name in (("original", "simplified") if k % 2 == 0 else ("simplified", "original")):
                d2 = _step(filters[name], run, k, scores[name], convergence_s)
                last[name] = d2 if d2 == d2 else last[name]
        for name, score in scores.items():
            score.final.append(last[name])
        pairs += run.t.size
    return {name: score.figures(pairs) for name, score in scores.items()}
