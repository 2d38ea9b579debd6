"""Discrete loop analysis of the paper 1 rate loop (gimbal_control.loop_design).

References: analytic margins of a ZOH integrator with a gain and d samples of delay, the
continuous second-order loop as T → 0, scipy.signal's own frequency response and margins
read off ``dbode``, and a time-domain run of the real ``LosRateController`` on the ZOH plant
that decays just below the computed gain margin and grows just above it.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from scipy import signal

from gimbal_control.linearize import linearize_gimbal
from gimbal_control.loop_design import (
    close_other_channels, closed_loop_matrix, controller_loop, gimbal_loop, is_stable, loop_response,
    margins, margins_full, max_omega_n_hz, pi_gains, siso_margins,
)
from gimbal_control.los_rate_controller import (
    DEFAULT_OMEGA_N_HZ, DEFAULT_RATE_HZ, LosRateController, LosRateControllerParams,
)


def test_pi_gains_formula():
    kp, ki = pi_gains(100.0, 0.8)
    w = 2 * math.pi * 100.0
    assert kp == pytest.approx(2 * 0.8 * w, rel=1e-15)
    assert ki == pytest.approx(w * w, rel=1e-15)


@pytest.mark.parametrize("d", [0, 1, 2])
def test_integrator_with_delay_matches_analytic(d):
    # L(z) = K T z^-d / (z - 1): |L| = K T / (2 sin(θ/2)), ∠L = -(π/2 + θ/2 + d θ), θ = ωT.
    T, K = 1e-3, 200.0
    loop = controller_loop(np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1)), 1.0 / T, K, 0.0, d)
    m = siso_margins(loop)
    theta_c = 2 * math.asin(K * T / 2)
    assert m.crossover_hz == pytest.approx(theta_c / (2 * math.pi * T), rel=1e-6)
    assert m.phase_margin_deg == pytest.approx(90.0 - math.degrees((d + 0.5) * theta_c), abs=1e-6)
    theta_pi = math.pi / (2 * d + 1)
    assert m.gain_margin_db == pytest.approx(20 * math.log10(2 * math.sin(theta_pi / 2) / (K * T)), abs=1e-6)
    assert m.stable


def test_continuous_limit_matches_second_order_loop():
    # T → 0: L(s) = (k_p s + k_i)/s², |L(jω_c)| = 1 at ω_c² = ω_n² (b + √(b² + 4))/2, b = 4ξ².
    zeta, fn = 0.8, 100.0
    b = 4 * zeta ** 2
    wc = 2 * math.pi * fn * math.sqrt((b + math.sqrt(b * b + 4)) / 2)
    pm = math.degrees(math.atan(2 * zeta * wc / (2 * math.pi * fn)))
    gm, pm_d, fc = margins(1e6, fn, zeta, delay_samples=0)
    assert fc == pytest.approx(wc / (2 * math.pi), rel=2e-3)
    assert pm_d == pytest.approx(pm, abs=0.3)
    assert gm > 60.0


# ss2tf leaves ~1e-20 leading numerator terms (the loop is strictly proper).
pytestmark = pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")


def test_response_matches_scipy_dfreqresp():
    siso = close_other_channels(gimbal_loop(2000.0, 40.0, 0.8, 1), 0)
    num, den = signal.ss2tf(siso.A, siso.B, siso.C, np.zeros((1, 1)))
    w_hz = np.array([5.0, 30.0, 70.0, 150.0, 400.0, 900.0])
    _, h = signal.dfreqresp(signal.dlti(num[0], den, dt=siso.dt), w=2 * np.pi * w_hz * siso.dt)
    ours = loop_response(siso, 2 * np.pi * w_hz)
    np.testing.assert_allclose(ours, -h, rtol=1e-5)


@pytest.mark.parametrize("rate_hz,fn,d", [(1000.0, 25.0, 1), (2000.0, 40.0, 0), (5000.0, 100.0, 1)])
def test_margins_match_scipy_dbode(rate_hz, fn, d):
    """Margins read off scipy.signal.dbode (interpolated on a fine grid) for each axis."""
    loop = gimbal_loop(rate_hz, fn, 0.8, d)
    pms, gms = [], []
    for ch in range(2):
        siso = close_other_channels(loop, ch)
        num, den = signal.ss2tf(siso.A, siso.B, -siso.C, np.zeros((1, 1)))
        sys = signal.dlti(num[0], den, dt=siso.dt)
        w = np.linspace(0.2 * fn, 0.5 * rate_hz * (1 - 1e-6), 200000) * 2 * np.pi * siso.dt
        _, mag_db, phase = signal.dbode(sys, w=w)
        phase = np.unwrap(np.radians(phase))
        phase -= 2 * np.pi * np.floor((phase[0] + np.pi) / (2 * np.pi))  # start in [-π, π)
        i = np.nonzero(np.diff(np.sign(mag_db)))[0][0]
        ph_c = np.interp(0.0, [mag_db[i + 1], mag_db[i]], [phase[i + 1], phase[i]])
        pms.append(180.0 + math.degrees(ph_c))
        below = np.nonzero(phase < -np.pi)[0]
        if below.size:
            j = below[0]
            gms.append(-np.interp(-np.pi, [phase[j], phase[j - 1]], [mag_db[j], mag_db[j - 1]]))
        elif abs(phase[-1] + np.pi) < 1e-3:  # reaches -180° at Nyquist (L real there)
            gms.append(-mag_db[-1])
        else:
            gms.append(math.inf)
    gm, pm, _ = margins(rate_hz, fn, 0.8, d)
    assert pm == pytest.approx(min(pms), abs=0.05)
    assert gm == pytest.approx(min(gms), abs=0.05)


def _simulate_gain(rate_hz, fn, d, gain, steps):
    """Real controller (no limits, no trim) on the ZOH-discretised linear plant with an
    extra gain at the plant input; returns the rate norm at the start and the end."""
    model = linearize_gimbal()
    T = 1.0 / rate_hz
    Phi, Gam, *_ = signal.cont2discrete((model.A_l, model.B_l, model.C_l, np.zeros((2, 2))), T, method="zoh")
    ctrl = LosRateController(LosRateControllerParams(
        rate_hz=rate_hz, omega_n_hz=fn, trim=False, anti_windup="none",
        azimuth_torque_limit_nm=math.inf, elevation_torque_limit_nm=math.inf))
    x = np.array([0.0, 0.0, 1e-6, -1e-6])
    queue = deque([(0.0, 0.0)] * d)
    norms = []
    for k in range(steps):
        # at rest the gyro reads the joint rates (θm ≈ 0: cos θm = 1 to 1e-12)
        tau = ctrl.step(k * T, (x[3], x[2]), (0.0, x[0], x[1]), (0.0, x[2], x[3]), (0.0, 0.0, 0.0))
        queue.append(tau)
        u = np.asarray(queue.popleft()) * gain
        x = Phi @ x + Gam @ u
        norms.append(math.hypot(x[2], x[3]))
        if norms[-1] > 1.0:  # diverged (a million times the start): stop before overflow
            break
    return max(norms[:50]), max(norms[-200:])


@pytest.mark.parametrize("d", [0, 1])
def test_time_domain_goes_unstable_just_past_gain_margin(d):
    rate_hz, fn = 1000.0, 25.0
    gm_db, _, _ = margins(rate_hz, fn, 0.8, d)
    g = 10 ** (gm_db / 20)
    start, end_below = _simulate_gain(rate_hz, fn, d, 0.93 * g, 3000)
    _, end_above = _simulate_gain(rate_hz, fn, d, 1.07 * g, 3000)
    assert end_below < 0.1 * start
    assert end_above > 10.0 * start
    loop = gimbal_loop(rate_hz, fn, 0.8, d)
    assert is_stable(closed_loop_matrix(loop, 0.99 * g))
    assert not is_stable(closed_loop_matrix(loop, 1.01 * g))


def test_neutral_angle_modes_are_exactly_two():
    ev = np.linalg.eigvals(closed_loop_matrix(gimbal_loop(1000.0, 25.0, 0.8, 1)))
    assert np.sum(np.abs(ev - 1.0) < 1e-9) == 2


def test_phase_margin_falls_with_omega_n_and_rate_table():
    pms = [margins(2000.0, f, 0.8, 1)[1] for f in (10.0, 30.0, 50.0, 70.0)]
    assert all(a > b for a, b in zip(pms, pms[1:]))
    # paper's ω_n: not enough margin at 2 kHz with one extra sample, enough at 5 kHz
    assert margins(2000.0, 100.0, 0.8, 1)[1] < 45.0
    assert margins(5000.0, 100.0, 0.8, 1)[1] > 45.0
    f1 = max_omega_n_hz(1000.0)
    f2 = max_omega_n_hz(2000.0)
    assert margins(1000.0, f1, 0.8, 1)[1] == pytest.approx(45.0, abs=0.05)
    # the delay lag scales with ω_c T, so the max ω_n scales with the rate
    assert f2 / f1 == pytest.approx(2.0, rel=0.02)


def test_default_design_keeps_45_degrees_with_one_sample_delay():
    m = margins_full(DEFAULT_RATE_HZ, DEFAULT_OMEGA_N_HZ, 0.8, 1)
    assert m.stable and m.phase_margin_deg >= 45.0 and m.gain_margin_db > 6.0
    assert DEFAULT_OMEGA_N_HZ <= max_omega_n_hz(DEFAULT_RATE_HZ)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="delay_samples"):
        gimbal_loop(1000.0, 25.0, 0.8, -1)
    with pytest.raises(ValueError, match="rate_hz"):
        gimbal_loop(0.0, 25.0, 0.8, 1)
    with pytest.raises(ValueError, match="omega_n_hz"):
        margins(1000.0, 0.0)
    with pytest.raises(ValueError, match="min_phase_margin_deg"):
        max_omega_n_hz(1000.0, 95.0)
