"""Kalman steps against closed forms and Monte Carlo consistency."""
import numpy as np
import pytest
from scipy.stats import chi2

from gimbal_kinematics.maths import kalman as kf


def test_joseph_update_equals_the_information_form():
    rng = np.random.default_rng(5)
    for _ in range(20):
        A = rng.normal(size=(4, 4))
        P = A @ A.T + 0.1 * np.eye(4)
        H = rng.normal(size=(2, 4))
        R = np.diag(rng.uniform(0.1, 1.0, 2))
        x, z = rng.normal(size=4), rng.normal(size=2)
        up = kf.joseph_update(x, P, z, H, R)
        P_info = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.inv(R) @ H)
        np.testing.assert_allclose(up.P, P_info, atol=1e-12)
        np.testing.assert_allclose(up.x, x + P_info @ H.T @ np.linalg.inv(R) @ (z - H @ x), atol=1e-12)
        assert up.accepted and np.all(np.linalg.eigvalsh(up.P) > 0)


def test_gate_rejects_outliers_and_nan():
    P, H, R = np.eye(2), np.eye(2), np.eye(2)
    gate = kf.chi2_gate(2, 0.999)
    assert gate == pytest.approx(chi2.ppf(0.999, 2))
    assert not kf.joseph_update(np.zeros(2), P, np.array([10.0, 0.0]), H, R, gate).accepted
    rejected = kf.joseph_update(np.zeros(2), P, np.array([np.nan, 0.0]), H, R, gate)
    assert not rejected.accepted and np.all(rejected.x == 0.0)


def test_random_walk_filter_is_consistent_by_nees():
    """A scalar-pair random walk observed in noise: time-averaged NEES inside its 95 % band."""
    rng = np.random.default_rng(11)
    F, Q, H, R = np.eye(2), np.diag([1e-3, 4e-3]), np.eye(2), np.diag([0.05, 0.02])
    runs, steps, values = 50, 200, []
    for _ in range(runs):
        truth, x, P = np.zeros(2), np.zeros(2), np.eye(2)
        truth = rng.multivariate_normal(np.zeros(2), P)
        for _ in range(steps):
            truth = truth + rng.multivariate_normal(np.zeros(2), Q)
            x, P = kf.predict(x, P, F, Q)
            up = kf.joseph_update(x, P, truth + rng.multivariate_normal(np.zeros(2), R), H, R)
            x, P = up.x, up.P
            values.append(kf.nees(truth - x, P))
    mean = np.mean(values)
    dof = 2 * runs * steps
    lo, hi = chi2.ppf([0.025, 0.975], dof) / (runs * steps)
    assert lo < mean < hi


def test_van_loan_matches_closed_form_first_order_markov():
    tau, sigma, dt = 30.0, 0.5, 0.1
    F, Qd = kf.van_loan(np.array([[-1.0 / tau]]), np.array([[2 * sigma**2 / tau]]), dt)
    phi = np.exp(-dt / tau)
    assert F[0, 0] == pytest.approx(phi, rel=1e-12)
    assert Qd[0, 0] == pytest.approx(sigma**2 * (1 - phi**2), rel=1e-10)


def test_bad_shapes_are_named():
    with pytest.raises(ValueError, match="shape"):
        kf.check_state(np.zeros(3), np.eye(2))
    with pytest.raises(ValueError, match="NaN"):
        kf.check_state(np.array([np.nan]), np.eye(1))
    with pytest.raises(ValueError, match="symmetric"):
        kf.check_state(np.zeros(2), np.array([[1.0, 0.5], [0.0, 1.0]]))
