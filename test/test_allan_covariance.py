"""The covariance of overlapping Allan variance points that gimbal-allan's fit uses: its
diagonal against Greenhall's EDF (allantools), the whole matrix against a seeded Monte Carlo
of numpy-made noise, and the selection it drives on records that hold no extra term."""
from __future__ import annotations

import math

import allantools
import numpy as np
import pytest

from gimbal_sim.allan.covariance import avar_covariance
from gimbal_sim.allan.fit import allan_curve, fit_noise_terms

TAU0 = 0.1


@pytest.mark.parametrize("term, alpha", [("white", 0), ("rrw", -2)])
def test_diagonal_is_greenhalls_edf(term, alpha):
    n, ms = 20_000, [2**k for k in range(6, 11)]  # Greenhall's EDF is a small-m approximation below 64
    cov = avar_covariance([n], ms, TAU0, {term: 1.0}, None)
    taus = np.array(ms) * TAU0
    avar = 1.0 / taus if term == "white" else taus / 3.0
    edf = np.array([allantools.edf_greenhall(alpha, 2, m, n + 1, overlapping=True) for m in ms])
    np.testing.assert_allclose(2.0 * avar**2 / np.diag(cov), edf, rtol=0.01)


def test_whole_matrix_matches_a_monte_carlo():
    rng = np.random.default_rng(7)
    n, runs, ms = 1024, 800, [1, 2, 4, 8, 16, 32]
    N, K = 1.0, 0.05
    curves = []
    for _ in range(runs):
        y = N / math.sqrt(TAU0) * rng.standard_normal(n) + np.cumsum(K * math.sqrt(TAU0) * rng.standard_normal(n))
        curves.append(allan_curve([y], TAU0, ms[-1] * TAU0).avar)
    mc = np.cov(np.array(curves).T)
    cov = avar_covariance([n], ms, TAU0, {"white": N, "rrw": K}, None)
    # variances to the Monte Carlo's own scatter (about sqrt(2/runs) = 5 % for a variance of a
    # variance, more for the skewed long-τ points); correlations to 3/sqrt(runs)
    np.testing.assert_allclose(np.diag(cov), np.diag(mc), rtol=0.2)
    corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    mc_corr = mc / np.sqrt(np.outer(np.diag(mc), np.diag(mc)))
    np.testing.assert_allclose(corr, mc_corr, atol=3.0 / math.sqrt(runs) + 0.02)
    assert corr[3, 4] > 0.3  # the correlation the fit allows for is there


def test_white_noise_and_random_walk_records_get_no_extra_term():
    # short records (1 h at 10 Hz) of the characterised gyro; nothing but the two terms may be detected
    N, K = 0.2 * math.pi / 180 / 60, 20 * math.pi / 180 / 3600 / 60
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        n = 36_000
        y = N / math.sqrt(TAU0) * rng.standard_normal(n) + np.cumsum(K * math.sqrt(TAU0) * rng.standard_normal(n))
        fit = fit_noise_terms(allan_curve([y], TAU0, n * TAU0 / 10))
        assert {t for t, e in fit.terms.items() if e.detected} == {"white", "rrw"}, seed
