"""The geo_pointing report's 'within budget' check: judged against the budget's
95 % radius, it reads about 95 % for an error drawn from the budget's own covariance and
fails for one 1.5 times larger, both at the closed-form fractions (Rayleigh); the 1σ RMS
fraction beside it is the closed form 1 − e⁻¹ of an equal-axes error."""
import math

import numpy as np
import pytest

from gimbal_sim.reports.geo_pointing import pointing_figures

N = 20_000


def _figures(scale: float, s1: float = 2e-3, s2: float = 2e-3) -> dict:
    rng = np.random.default_rng(7)
    t = np.arange(N) * 0.01
    d = rng.normal(size=(N, 2)) * (s1, s2) * scale
    budget = np.tile([math.hypot(s1, s2), s1, s2], (N // 10, 1))  # published at a tenth of the error's rate
    return pointing_figures(t, np.hypot(d[:, 0], d[:, 1]), t[::10], budget, acquire_s=0.0)


def _binomial(p: float) -> float:
    return 4.5 * math.sqrt(p * (1.0 - p) / N)


def test_an_error_as_budgeted_is_within_the_95_percent_radius_95_percent_of_the_time():
    f = _figures(1.0)
    assert f["budget_95_mean_mrad"] == pytest.approx(2.0 * math.sqrt(-2.0 * math.log(0.05)), rel=1e-12)
    assert f["within_budget_95_fraction"] == pytest.approx(0.95, abs=_binomial(0.95))
    inside_rms = 1.0 - math.exp(-1.0)  # Rayleigh: P(R ≤ √2 σ)
    assert f["within_budget_1sigma_fraction"] == pytest.approx(inside_rms, abs=_binomial(inside_rms))


def test_an_error_larger_than_budgeted_fails_the_95_percent_check():
    f = _figures(1.5)
    expected = 1.0 - 0.05 ** (1.0 / 1.5 ** 2)  # Rayleigh: P(R ≤ r95 / 1.5)
    assert f["within_budget_95_fraction"] == pytest.approx(expected, abs=_binomial(expected))
    assert f["within_budget_95_fraction"] < 0.95


def test_nothing_after_the_acquisition_time_gives_none():
    t = np.arange(10) * 0.01
    assert pointing_figures(t, np.zeros(10), t, np.tile([1e-3, 1e-3, 0.0], (10, 1)), acquire_s=1.0) is None
