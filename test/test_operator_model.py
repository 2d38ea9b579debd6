"""Simulated sight operator (gimbal_sim.world.operator_model) against closed forms, closing the
loop on a kinematic LOS integrated here with scipy's rotations: the sight frame turns at the
operator's command plus a known constant drift d away from the target.

Closed form of one correction cycle (module docstring of the model): the error drifts from
the settle band to the tolerance in (tol − band)/d, waits the reaction time τ (reaching
ε0 = tol + dτ), then, with the creep d led, decays as ε0 e^{−Kt} to the band:
P = (tol − band)/d + τ + ln(ε0/band)/K. The first correction starts from ε = 0, at tol/d + τ.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_sim.world.operator_model import OperatorModel, OperatorModelParams, sight_error

RATE_HZ = 200
DT_NS = 1_000_000_000 // RATE_HZ
TOL, BAND, TAU, K = 1e-3, 0.3e-3, 0.25, 1.5  # the defaults, in SI


def fly(drift_qr, duration_s, params=None, drift_of_t=None):
    """Integrate C_fm with ω_m = (0, q, r) = command + drift (zero-order hold over each
    step); the target is the initial LOS. Returns the model and the error series [rad]."""
    model = OperatorModel(params)
    C = np.eye(3)
    target = np.array([1.0, 0.0, 0.0])
    errors = []
    for k in range(int(duration_s * RATE_HZ) + 1):
        t_ns = k * DT_NS
        q, r = model.step(t_ns, C, target)
        dq, dr = drift_qr if drift_of_t is None else drift_of_t(t_ns * 1e-9)
        C = C @ Rotation.from_rotvec([0.0, (q + dq) / RATE_HZ, (r + dr) / RATE_HZ]).as_matrix()
        errors.append(model.error)
    return model, np.array(errors)


def cycle(d, tol=TOL, band=BAND, tau=TAU, k=K, peak=math.inf):
    """(period, first onset, off-target time per cycle) [s] for drift d [rad/s]; with the
    rate magnitude saturated at ``peak``: |ε'| = peak − d down to ε_s = (peak − d)/K."""
    eps0 = tol + d * tau
    eps_s = min(eps0, (peak - d) / k)

    def slew_to(level):
        sat = max(0.0, eps0 - max(eps_s, level)) / (peak - d) if eps0 > eps_s else 0.0
        return sat + (math.log(eps_s / level) / k if eps_s > level else 0.0)

    return (tol - band) / d + tau + slew_to(band), tol / d + tau, tau + slew_to(tol)


def check_cycle(model, d, duration_s, rel=0.01, **kw):
    period, first, off = cycle(d, **kw)
    n = int((duration_s - first) / period) + 1
    s = model.statistics()
    print(f"d = {d * 1e3:.3f} mrad/s over {duration_s:.2f} s: period {s['mean_time_between_corrections_s']:.4f} s "
          f"(closed form {period:.4f}), {s['corrections']} corrections (closed form {n}), "
          f"{s['corrections_per_min']:.2f}/min, time on target {s['time_on_target_fraction']:.4f} "
          f"(closed form {1.0 - n * off / duration_s:.4f})")
    assert s["corrections"] == n
    assert s["mean_time_between_corrections_s"] == pytest.approx(period, rel=rel)
    assert s["corrections_per_min"] == pytest.approx(60.0 * n / duration_s, rel=1e-3)
    assert s["time_on_target_fraction"] == pytest.approx(1.0 - n * off / duration_s, abs=rel)
    return period, s


def test_azimuth_drift_gives_the_closed_form_correction_period():
    d = 0.5e-3  # 0.5 mrad/s, paper 1's uncorrected drift (3–4° in 2 min is 0.44–0.58 mrad/s)
    period, first, _ = cycle(d)
    duration = first + 11.5 * period  # ends mid-cycle: 12 corrections, the last one complete
    model, errors = fly((0.0, -d), duration)
    period, s = check_cycle(model, d, duration)
    assert errors.max() == pytest.approx(TOL + d * TAU, rel=0.01)  # ε0 = tol + dτ, never more
    assert s["cancelled_reactions"] == 0 and s["rejected_inputs"] == 0
    assert 60.0 / period == pytest.approx(23.7, abs=0.1)  # ~24 corrections a minute, steady state


def test_diagonal_drift_is_corrected_along_its_direction():
    d_q, d_r = 0.3e-3, -0.4e-3  # |d| = 0.5 mrad/s
    d = math.hypot(d_q, d_r)
    period, first, _ = cycle(d)
    duration = first + 7.5 * period
    model, errors = fly((d_q, d_r), duration)
    check_cycle(model, d, duration)
    assert errors.max() == pytest.approx(TOL + d * TAU, rel=0.01)


def test_saturated_corrections_follow_the_peak_rate_closed_form():
    """Peak 0.1 °/s (1.75 mrad/s) with d = 1 mrad/s: the rate is pinned at the peak from
    ε0 = 1.25 mrad down to (peak − d)/K = 0.50 mrad, then decays exponentially."""
    peak = math.radians(0.1)
    d = 1e-3
    params = OperatorModelParams(peak_rate_deg_s=0.1)
    period, first, _ = cycle(d, peak=peak)
    assert (TOL + d * TAU) * K + d > peak  # the regime under test
    duration = first + 9.5 * period
    model, _ = fly((0.0, -d), duration, params)
    check_cycle(model, d, duration, peak=peak)
    assert max(abs(v) for v in model.command) <= peak


def test_without_reaction_time_the_operator_is_a_pure_gain():
    """τ = 0: no creep seen, ω = K ε: ε → d/K + (tol − d/K) e^{−Kt}, so the slew lasts
    ln((tol − d/K)/(band − d/K))/K."""
    d = 0.3e-3
    params = OperatorModelParams(reaction_time_s=0.0)
    slew = math.log((TOL - d / K) / (BAND - d / K)) / K
    period = (TOL - BAND) / d + slew
    duration = TOL / d + 6.5 * period
    model, _ = fly((0.0, -d), duration, params)
    s = model.statistics()
    assert s["corrections"] == 7
    assert s["mean_time_between_corrections_s"] == pytest.approx(period, rel=0.01)


def test_a_perfect_los_needs_no_correction():
    model, errors = fly((0.0, 0.0), 60.0)
    s = model.statistics()
    assert s["corrections"] == 0 and s["corrections_per_min"] == 0.0
    assert s["time_on_target_fraction"] == 1.0 and s["observed_s"] == pytest.approx(60.0)
    assert math.isnan(s["mean_time_between_corrections_s"])
    assert errors.max() < 1e-12


def test_an_error_that_comes_back_within_the_reaction_time_is_not_corrected():
    d = 1e-3
    t_turn = TOL / d + 0.1  # 0.1 s past the tolerance, then the drift reverses
    model, _ = fly(None, 3.0, drift_of_t=lambda t: (0.0, -d if t < t_turn else d))
    s = model.statistics()
    assert (s["corrections"], s["cancelled_reactions"]) == (0, 1)


def test_sight_error_angle_and_direction():
    # target 2 mrad above and 3 mrad right of the LOS (FRD: above is −z)
    el, az = 2e-3, 3e-3
    v = Rotation.from_euler("ZY", [az, el]).apply([1.0, 0.0, 0.0])  # +el about y raises x towards −z
    assert v[2] < 0.0 and v[1] > 0.0
    eps, e_q, e_r = sight_error(np.eye(3), v)
    assert eps == pytest.approx(math.acos(v[0]), rel=1e-12)
    assert (e_q, e_r) == pytest.approx((el, az), rel=1e-5)  # small angles: (elevation, azimuth) offsets
    # any frame f: the same error when the sight and the target turn together
    R = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix()
    assert sight_error(R, R @ v) == pytest.approx((eps, e_q, e_r), abs=1e-15)


def test_bad_input_is_counted_and_never_acted_on():
    model = OperatorModel()
    off = Rotation.from_rotvec([0.0, 0.0, 5e-3]).apply([1.0, 0.0, 0.0])
    assert model.step(0, np.eye(3), off) == (0.0, 0.0)
    bad_c = np.eye(3)
    bad_c[1, 1] = math.nan
    for t, C, u in ((1, bad_c, off), (2, np.eye(3), [0.0, 0.0, 0.0]), (3, np.eye(3), [math.inf, 0.0, 0.0]),
                    (4, np.eye(3), [1.0, 0.0])):
        model.step(t * DT_NS, C, u)
    assert model.step(0, np.eye(3), off) == (0.0, 0.0)  # duplicate stamp
    s = model.statistics()
    assert (s["rejected_inputs"], s["rejected_stamps"], s["observed_s"]) == (4, 1, 0.0)
    with pytest.raises(TypeError):
        model.step(0.5, np.eye(3), off)
    # a clock jump back restarts watching: the reaction starts again from the new stamp
    for k in range(1, 60):
        model.step(1_000 * DT_NS + k * DT_NS, np.eye(3), off)
    assert model.phase == "slew" and model.corrections == 1
    model.step(10 * DT_NS, np.eye(3), off)
    assert model.phase == "react" and model.statistics()["clock_jumps"] == 1


@pytest.mark.parametrize("name, value", [
    ("tolerance_mrad", 0.0), ("settle_band_mrad", 1.0), ("settle_band_mrad", -0.1), ("reaction_time_s", -0.1),
    ("reaction_time_s", math.inf), ("peak_rate_deg_s", math.nan), ("gain_1_s", 0.0), ("clock_jump_s", -1.0),
])
def test_bad_parameters_are_refused_naming_them(name, value):
    with pytest.raises(ValueError, match=name):
        OperatorModelParams(**{name: value})
