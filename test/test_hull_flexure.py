"""The hull flexure truth (``flexure_dynamic_model: hull``) against independent references:
the sea spectrum against its integral, each mode against the closed-form second-order
transfer function (scipy.signal), the truth's spectrum against the band the 18-state filter
assumes (Welch against the band's analytic PSD), the scenarios' data, and paper 5's headline
on sea state 4 at test scale against the bound the sea-state study sets."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, signal

from gimbal_estimators.flexure_kf import FlexureKfParams
from gimbal_kinematics.maths.units import ARCSEC
from gimbal_sim.experiments.flexure import model_params, run_flexure_comparison
from gimbal_sim.graph import scenario as scn
from gimbal_sim.world.sensors import FlexureParams, HullParams, SecondOrderGaussMarkov, ShipFlexureTruth
from gimbal_sim.world.sensors.hull_flexure import (
    NATO_SEA_STATES, HullFlexure, bretschneider_psd, encounter_frequency, mode_discrete)

FS = 10.0  # the ship_flexure simulation rate [Hz]


@pytest.mark.parametrize("sea_state", [3, 4, 5])
def test_sea_spectrum_integrates_to_hs_squared_over_16(sea_state):
    hs, tp = NATO_SEA_STATES[sea_state]
    m0, _ = integrate.quad(lambda w: float(bretschneider_psd(w, hs, tp)), 1e-3, 50.0, limit=200)
    assert m0 == pytest.approx(hs * hs / 16.0, rel=1e-4)
    # Its peak is at the modal period: dS/dω = 0 at ω_p = 2π/T_p.
    w = np.linspace(0.2, 3.0, 28001)
    assert w[np.argmax(bretschneider_psd(w, hs, tp))] == pytest.approx(2 * math.pi / tp, abs=2e-4)
    # The synthesised sea carries the spectrum's variance over its frequency range (random
    # frequencies within each bin, seeded), within 2 %.
    hull = HullFlexure(HullParams(sea_state=sea_state), np.random.default_rng(7), 0.1)
    in_range, _ = integrate.quad(lambda x: float(bretschneider_psd(x, hs, tp)), 0.2, 3.0, limit=200)
    assert np.sum(hull.amplitude ** 2) / 2 == pytest.approx(in_range, rel=0.02)
    assert in_range > 0.97 * m0


def test_nato_table_and_encounter_frequency():
    assert NATO_SEA_STATES[3] == (0.88, 7.5) and NATO_SEA_STATES[4] == (1.88, 8.8) and NATO_SEA_STATES[5] == (3.25, 9.7)
    # Head seas at 15 kn: a 0.7 rad/s wave (126 m) is met at 0.7 + 0.7²/g · 7.72 = 1.086 rad/s.
    assert float(encounter_frequency(0.7, 7.72, math.pi)) == pytest.approx(0.7 + 0.49 / 9.80665 * 7.72, rel=1e-12)
    assert float(encounter_frequency(0.7, 0.0, 1.0)) == 0.7
    with pytest.raises(ValueError, match="sea_state"):
        HullParams(sea_state=7)


@pytest.mark.parametrize("freq_hz, zeta, omega", [(1.2, 0.02, 0.7), (1.2, 0.02, 2 * math.pi * 1.2),
                                                  (1.8, 0.02, 9.0), (2.4, 0.05, 3.0)])
def test_mode_step_matches_the_second_order_transfer_function(freq_hz, zeta, omega):
    """A sinusoid through the stepped mode (exact first-order-hold step at 10 Hz and at 100 Hz)
    against scipy.signal's frequency response of ω_n²/(s² + 2ζω_n s + ω_n²), times the
    first-order hold's own gain on a sampled sinusoid, sinc²(ωΔt/2) (zero phase; 0.953 at
    1.2 Hz sampled at 10 Hz)."""
    wn = 2 * math.pi * freq_hz
    _, h = signal.freqresp(signal.lti([wn * wn], [1.0, 2 * zeta * wn, wn * wn]), w=[omega])
    for fs, tol in ((10.0, 2e-3), (100.0, 5e-4)):
        dt = 1.0 / fs
        hold = np.sinc(omega * dt / 2 / math.pi) ** 2
        Phi, g0, g1 = mode_discrete(freq_hz, zeta, dt)
        n = int(round((10.0 / (zeta * wn) + 40.0) * fs))  # 10 time constants of the transient, then 40 s
        t = np.arange(n + 1) * dt
        u = np.sin(omega * t)
        x = np.zeros(2)
        q = np.empty(n + 1)
        q[0] = 0.0
        for k in range(n):
            x = Phi @ x + g0 * u[k] + g1 * (u[k + 1] - u[k]) / dt
            q[k + 1] = x[0]
        tail = t > t[-1] - 40.0
        # least-squares amplitude and phase of the steady state
        basis = np.column_stack([np.sin(omega * t[tail]), np.cos(omega * t[tail])])
        a, b = np.linalg.lstsq(basis, q[tail], rcond=None)[0]
        got = complex(a, b)  # q = Re{got · e^{jωt}/j}: sin -> a, cos -> b
        assert abs(got) == pytest.approx(abs(h[0]) * hold, rel=tol), fs
        assert math.atan2(b, a) == pytest.approx(np.angle(h[0]), abs=2 * tol + 1e-4), fs


def test_stepped_hull_flexure_equals_its_closed_form_response():
    hull = HullFlexure(HullParams(sea_state=5), np.random.default_rng(3), 1.0 / FS)
    sigma = hull.rms()
    for k in range(1, 3001):
        hull.step()
        if k % 500 == 0:
            err = np.array(hull.value) - hull.steady_state(hull.t)
            assert np.all(np.abs(err) < 0.01 * sigma), (k, err / sigma)


@pytest.fixture(scope="module")
def sea_state_4_series():
    """2 h of the sea state 4 hull truth's dynamic part at 10 Hz, and of the filter's band."""
    n = int(7200 * FS)
    hull = HullFlexure(HullParams(sea_state=4), np.random.default_rng(11), 1.0 / FS)
    kf = FlexureKfParams()
    band = SecondOrderGaussMarkov([x * ARCSEC for x in kf.dynamic_rms_arcsec], kf.dynamic_beta_per_s,
                                  kf.dynamic_freq_rad_s, np.random.default_rng(12), 1.0 / FS)
    xs, bs = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        hull.step()
        band.step()
        xs[k] = hull.value
        bs[k] = band.value
    return xs, bs, kf


def _analytic_band_psd(w, sigma, beta, lam):
    """One-sided PSD per rad/s of the filter's band: q |H(jω)|²/π, H = 1/(s² + 2βs + ω0²),
    q = 4βω0²σ² (paper 5 eq. 12's continuous form), from scipy.signal's frequency response."""
    w0sq = beta * beta + lam * lam
    _, h = signal.freqresp(signal.lti([1.0], [1.0, 2 * beta, w0sq]), w=w)
    return 4 * beta * w0sq * sigma * sigma * np.abs(h) ** 2 / math.pi


def test_truth_spectrum_is_not_the_filters_band(sea_state_4_series):
    """Independence: the hull's flexure sits in the encounter band of the waves, the filter's
    band (critically damped, 10 s) mostly below it. Welch of each against the band's analytic
    PSD: the band's own sample agrees with it; the hull's differs by a factor > 10."""
    xs, bs, kf = sea_state_4_series
    f, p_hull = signal.welch(xs, fs=FS, nperseg=4096, axis=0)
    _, p_band = signal.welch(bs, fs=FS, nperseg=4096, axis=0)
    w = 2 * math.pi * f
    pw_hull, pw_band = p_hull / (2 * math.pi), p_band / (2 * math.pi)
    sig = np.array(kf.dynamic_rms_arcsec) * ARCSEC
    beta = np.broadcast_to(kf.dynamic_beta_per_s, (3,))
    lam = np.broadcast_to(kf.dynamic_freq_rad_s, (3,))
    dw = w[1] - w[0]
    low, wave = (w > 0) & (w < 0.2), (w >= 0.3) & (w < 3.0)
    for a in range(3):
        model = _analytic_band_psd(w, sig[a], beta[a], lam[a])
        # the method: the band's own sample matches its analytic PSD in both bands (within 25 %)
        for sel in (low, wave):
            assert np.sum(pw_band[sel, a]) == pytest.approx(np.sum(model[sel]), rel=0.25)
        # the hull: wave-band power a decade above the band's, low-frequency power a decade below
        frac_hull = np.sum(pw_hull[wave, a]) / np.sum(pw_hull[w > 0, a])
        frac_model = np.sum(model[wave]) / (sig[a] ** 2 / dw)
        assert frac_hull > 0.9 and frac_model < 0.2, (a, frac_hull, frac_model)
        assert np.sum(pw_hull[low, a]) < 0.1 * np.sum(model[low]) * (np.var(xs[:, a]) / sig[a] ** 2)
    # the spectral peak: the hull's pitch (vertical bending) at the encounter peak, the band's at 0
    peak = w[np.argmax(pw_hull[:, 1])]
    assert 0.5 < peak < 1.3
    assert w[np.argmax(_analytic_band_psd(w[1:], sig[1], beta[1], lam[1]))] < 0.01


def test_hull_is_selected_by_the_parameter_and_the_band_is_kept():
    band = ShipFlexureTruth(FlexureParams(), np.random.default_rng(0), 0.1)
    hull = ShipFlexureTruth(FlexureParams(dynamic_model="hull"), np.random.default_rng(0), 0.1)
    assert isinstance(band.dynamic, SecondOrderGaussMarkov) and isinstance(hull.dynamic, HullFlexure)
    assert band.quasi_static_angle(100.0) == hull.quasi_static_angle(100.0)
    with pytest.raises(ValueError, match="dynamic_model"):
        FlexureParams(dynamic_model="sea")


def test_scenarios_ship_flexure_is_sea_state_4_hull_and_the_band_is_kept():
    base = scn.load("ship_flexure")
    sm = base.nodes["sensor_models"]["params"]
    assert sm["flexure_dynamic_model"] == "hull" and sm["flexure_sea_state"] == 4
    # ship_flexure_sea_states' sea_state_4 is ship_flexure (same nodes, parameters, duration, rate)
    ss4 = scn.variant(scn.load("ship_flexure_sea_states"), "sea_state_4")
    assert ss4.nodes == base.nodes and ss4.duration_s == base.duration_s and ss4.sim_rate_hz == base.sim_rate_hz
    for n in (3, 5):
        v = scn.variant(scn.load("ship_flexure_sea_states"), f"sea_state_{n}")
        assert v.nodes["sensor_models"]["params"]["flexure_sea_state"] == n
    # the filter keeps its own model: no estimator parameter differs from the band scenario's
    band = scn.load("ship_flexure_band")
    assert "flexure_dynamic_model" not in band.nodes["sensor_models"]["params"]
    for node in ("flexure_random_constant", "flexure_random_walk_rate"):
        assert base.nodes[node]["params"] == band.nodes[node]["params"]


#: Test scale of the headline: seeds, run length [s] and scoring start [s].
HEADLINE_SEEDS, HEADLINE_S, HEADLINE_CONV_S = (0, 1), 1500.0, 600.0
#: The bound the sea-state study sets at this scale (docs/results/paper5.md: the hull under a
#: sea), per axis (roll, pitch, yaw) [″], on the mean over HEADLINE_SEEDS: 1.25 times the worst
#: of seeds 0..7 at this scale (55.7″, 153.7″, 23.2″; mean 30.4″, 147.9″, 20.6″). Paper 5: 20″.
HEADLINE_BOUND_ARCSEC = (70.0, 192.0, 29.0)
#: ... and the pitch miss it pins: at least 100″ (best of the eight seeds 138.6″), so that a
#: change that moves the figure toward the paper's 20″ is seen and explained, not absorbed.
HEADLINE_PITCH_MISS_ARCSEC = 100.0


def test_headline_sea_state_4_accuracy_against_the_study_bound():
    """Paper 5's 20″ on the hull it was not tuned to: sea state 4, random-walk-rate model,
    both attitude-matching methods, short runs on the core engine."""
    kf = FlexureKfParams()
    flex = FlexureParams(dynamic_model="hull", hull=HullParams(sea_state=4))
    rms = {"simplified": [], "original": []}
    for seed in HEADLINE_SEEDS:
        res = run_flexure_comparison(HEADLINE_S, seed, models=model_params(("random_walk_rate",), kf,
                                                                           methods=("simplified", "original")),
                                     sim_rate_hz=FS, lgu_rate_hz=FS, convergence_s=HEADLINE_CONV_S, flexure=flex)
        rms["simplified"].append(res["random_walk_rate"].metrics["total_rms_arcsec"])
        rms["original"].append(res["random_walk_rate_original"].metrics["total_rms_arcsec"])
    mean = {k: np.mean(v, axis=0) for k, v in rms.items()}
    print({k: np.round(v, 1).tolist() for k, v in mean.items()})
    assert np.all(np.abs(mean["original"] - mean["simplified"]) <= 0.05 * mean["simplified"] + 0.5)
    assert np.all(mean["simplified"] < np.array(HEADLINE_BOUND_ARCSEC, float))
    assert mean["simplified"][1] > HEADLINE_PITCH_MISS_ARCSEC


@pytest.mark.parametrize("args, named", [(["--duration", "0"], "--duration"), (["--seeds", "1", "1"], "--seeds"),
                                         (["--spectrum", "--duration", "600"], "--spectrum"),
                                         (["--budget", "--duration", "600"], "--budget"),
                                         (["--sea-states", "7"], "--sea-states")])
def test_flexure_sea_command_refuses_bad_input_naming_it(args, named, capsys):
    from gimbal_sim.experiments import flexure_sea

    with pytest.raises(SystemExit) as exc:
        flexure_sea.main(args)
    assert exc.value.code == 2 and named in capsys.readouterr().err
