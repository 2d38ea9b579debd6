"""Paper 2's studies (experiments.encoder_fusion_study, reports.gyro_encoder) on short runs,
against closed forms and independent computations (no ROS)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats as sps

from gimbal_control.fusion_kf import FusionKfParams
from gimbal_sim.campaign.experiment import plan_experiment
from gimbal_sim.campaign.spec import CampaignError, CampaignSpec
from gimbal_sim.core.core_loop import run_core_loop
from gimbal_sim.experiments import encoder_fusion_study as study
from gimbal_sim.experiments.encoder_fusion import UAV_PROFILE
from gimbal_sim.experiments.registry import EXPERIMENTS
from gimbal_sim.graph.scenario import apply_set, load
from gimbal_sim.reports.gyro_encoder import GyroEncoderSeries, figures
from imu_grades import no_grade

DEG = math.pi / 180.0


# ---------------------------------------------------------------------------- Figs. 2 and 3
def _core_series(scenario) -> tuple[GyroEncoderSeries, list]:
    """The gyro_encoder report's series from the scenario's cores (what the bag would hold),
    and the true turret angle at each encoder sample."""
    gyro, enc, truth = [], [], []

    def observe(bus):
        if bus.gyro is not None:
            gyro.append((bus.gyro.t, bus.gyro.r_m, bus.gyro.true_bias[1]))
        if bus.encoders is not None:
            enc.append((bus.encoders.t, bus.encoders.angles, bus.encoders.rates))
            truth.append(bus.truth.joint_position)

    run_core_loop(scenario, observer=observe)
    g = np.array([(t, r) for t, r, _ in gyro])
    series = GyroEncoderSeries(t_gyro=g[:, 0], gyro_r=g[:, 1], t_enc=np.array([e[0] for e in enc]),
                               enc_pos=np.array([e[1] for e in enc]), enc_vel=np.array([e[2] for e in enc]),
                               bias_r=np.array([b for *_, b in gyro]))
    return series, truth


def test_fig3_encoder_speed_is_the_count_difference_over_the_gate():
    """Slow rotation: each encoder speed is (floor(θ(t)/δ + ½) − floor(θ(t − T_g)/δ + ½)) δ / T_g
    with θ(t) = 1 °/s · t the prescribed turret angle (the model's mid-tread count), held
    between gates; its mean is the true 1 °/s and it only takes whole counts per gate."""
    scenario = dataclasses.replace(load("gimbal_gyro_encoder_slow"), duration_s=12.0)
    s, _ = _core_series(scenario)
    delta, gate, omega = 2 * math.pi / 1024, 0.2, 1.0 * DEG
    counts = lambda t: np.floor(omega * t / delta + 0.5)  # noqa: E731
    steps = round(gate * 100)
    expected = np.zeros(len(s.t_enc))
    for k in range(steps, len(s.t_enc)):
        last_gate = k - k % steps  # the speed of the last completed gate, held
        t1 = s.t_enc[last_gate]
        expected[k] = (counts(t1) - counts(t1 - gate)) * delta / gate
    np.testing.assert_allclose(s.enc_vel[:, 0], expected, rtol=0, atol=1e-12)
    fig = figures(s)
    assert set(fig["encoder_speed_levels_deg_s"]) <= {0.0, 1.757812, 3.515625}
    # the gyro sees the rotation at the elevation equilibrium: r_m / cos θm ≈ 1 °/s + bias
    # (GM drift: 0.02 °/s RMS; scale error 0.2 %)
    assert fig["gyro_rate_mean_deg_s"] == pytest.approx(1.0 - 250.0 / 3600.0 / math.cos(26.5651 * DEG), abs=0.05)
    assert fig["encoder_angle_change_deg"] == pytest.approx(12.0, abs=360.0 / 1024)


def test_fig2_gyro_integrated_angle_at_rest_is_bias_times_t():
    """At rest with a constant bias only (no drift walk, no noise, no scale error): the
    gyro-integrated angle is b·t / cos θm exactly and the encoders never move."""
    scenario = load("gimbal_gyro_encoder_rest")
    for assign in ("sensor_models.gimbal_gyro_bi_deg_h=0.0", "sensor_models.gimbal_gyro_arw_deg_rt_h=0.0",
                   "sensor_models.gimbal_gyro_scale_factor_ppm=[0.0, 0.0]", *no_grade("gimbal_gyro")):
        scenario = apply_set(scenario, assign)
    scenario = dataclasses.replace(scenario, duration_s=30.0)
    s, _ = _core_series(scenario)
    fig = figures(s)
    b = -250.0 / 3600.0  # deg/s about r_m
    cos_th = math.cos(math.floor(-26.5651 * DEG / (2 * math.pi / 1024) + 0.5) * 2 * math.pi / 1024)
    assert fig["gyro_angle_final_deg"] == pytest.approx(b * 30.0 / cos_th, rel=1e-9)
    assert fig["encoder_angle_change_deg"] == 0.0 and fig["encoder_speed_levels_deg_s"] == [0.0]
    assert fig["drift_deg"] == pytest.approx(fig["bias_integral_deg"], rel=1e-9)


# ---------------------------------------------------------------------------- the R/Q sweep
def test_rq_plan_covers_the_papers_pairs_and_the_mapping_is_in_counts():
    spec = CampaignSpec(scenario="", experiment="encoder_fusion_rq", seeds=(1, 2), engine="core")
    plan = plan_experiment(spec, EXPERIMENTS["encoder_fusion_rq"])
    points = {study.parse_rq(r.variant) for r in plan.runs}
    assert {(0.1, 0.01), (0.1, 0.5), (1.0, 0.1)} <= points
    assert len(plan.runs) == 2 * len(study.RQ_R) * len(study.RQ_Q)
    # R = 0.1 counts² -> σ_z = √0.1 counts; Q₁₁ = q1·T = Q counts² per 0.2 s step
    kf = study.paper_kf(0.1, 0.01)
    delta = 360.0 / 1024
    assert kf.r_deg == pytest.approx(math.sqrt(0.1) * delta, rel=1e-12)
    assert kf.q_angle_deg_rt_s ** 2 * 0.2 == pytest.approx(0.01 * delta ** 2, rel=1e-12)
    base = FusionKfParams()
    assert kf.q_drift_deg_s_rt_s / kf.q_angle_deg_rt_s == pytest.approx(
        base.q_drift_deg_s_rt_s / base.q_angle_deg_rt_s, rel=1e-12)
    with pytest.raises(CampaignError, match="engine graph is not available"):
        plan_experiment(CampaignSpec(scenario="", experiment="encoder_fusion_rq", seeds=(1,), engine="graph"),
                        EXPERIMENTS["encoder_fusion_rq"])


def test_velocity_split_separates_a_slow_offset_from_gate_to_gate_noise():
    rng = np.random.default_rng(7)
    t = np.arange(20000) / 1000.0
    gates = np.repeat(rng.normal(0.0, 0.01, 100), 200)
    err = np.stack([0.05 + gates, np.full(t.size, -0.02)], axis=1)
    slow, fast = study.velocity_split(t, err, 0.2, window_gates=100)
    assert slow == pytest.approx([abs(0.05 + gates[::200].mean()), 0.02], rel=1e-9)
    assert fast[1] == pytest.approx(0.0, abs=1e-15)


# ---------------------------------------------------------------------------- the headline
def test_ratio_interval_is_scipys_t_interval_on_the_same_numbers():
    rng = np.random.default_rng(3)
    enc = rng.uniform(15e3, 25e3, 10)
    fused = rng.uniform(0.5e3, 2.5e3, 10)
    out = study.ratio_interval(enc.tolist(), fused.tolist())
    r = fused / enc
    lo, hi = sps.t.interval(0.95, len(r) - 1, loc=r.mean(), scale=sps.sem(r))
    assert out["ci95"] == pytest.approx([lo, hi], rel=1e-12)
    assert out["n"] == 10 and out["mean"] == pytest.approx(r.mean(), rel=1e-12)


def test_disturbance_scales_every_amplitude_and_draws_phases_from_the_seed():
    scaled = study.disturbance(0.2)
    for key, terms in UAV_PROFILE.items():
        assert [t[0] for t in scaled[key]] == pytest.approx([0.2 * t[0] for t in terms], rel=1e-15)
        assert [t[1:] for t in scaled[key]] == [t[1:] for t in terms]
    a, b, c = study.disturbance(0.2, 1), study.disturbance(0.2, 1), study.disturbance(0.2, 2)
    assert a == b and a != c
    phases = np.array([t[2] for terms in a.values() for t in terms])
    assert np.all((phases >= 0) & (phases < 2 * math.pi))


def test_headline_graph_engine_takes_the_scale_but_not_seeded_phases():
    exp = EXPERIMENTS["encoder_fusion"]
    spec = CampaignSpec(scenario="", experiment="encoder_fusion", seeds=(1,), engine="graph",
                        options=(("disturbance_scale", 0.2),))
    plan = plan_experiment(spec, exp)
    assert {r.variant for r in plan.runs} == {"encoder", "gyro", "fused"}
    with pytest.raises(CampaignError, match="random_phases"):
        plan_experiment(dataclasses.replace(spec, options=(("random_phases", True),)), exp)


def test_headline_core_run_gives_the_reports_figures_and_fusion_wins():
    """Short core runs on the paper's baseline: the encoder_fusion report's figures, and the
    fused loop's RMS well under the encoder loop's on the same disturbance."""
    options = {**study.HEADLINE_DEFAULTS, "duration_s": 8.0, "disturbance_scale": study.PAPER_BASELINE_SCALE,
               "random_phases": True}
    enc = study.headline_run("encoder", 4, options)
    fused = study.headline_run("fused", 4, options)
    assert enc["mode"] == "encoder" and fused["mode"] == "fused"
    assert fused["stabilization_error_urad"]["rms_after_settle"] * 4 < enc["stabilization_error_urad"]["rms_after_settle"]


def test_paper_baseline_scale_gives_the_papers_encoder_only_peaks():
    """PAPER_BASELINE_SCALE is chosen so that the encoder-only loop's peaks are paper 2's
    "even 1.2 deg" (20.9 mrad). Seeds 1-3 of the headline's 20 s runs (peak after the 5 s
    settle, each seed its own disturbance phases; about 2.6 s of CPU): their mean within 10 %
    of 1.2°, each seed within 20 %. Over seeds 1-10 the peaks are 21.0 ± 1.6 mrad
    (docs/results/paper2.md), so a 3-seed mean spreads by about 0.9 mrad: the 10 % band
    (±2.1 mrad) is 2.3 of that, the 20 % band 2.7 times the seed spread. The peak grows only
    slowly with the scale (seeds 1-3: 19.3, 21.3, 24.1 mrad at 0.15, 0.2, 0.25), so this
    pins the baseline's size (a change of profile, encoder or controller that moves the peak
    by more than ~10 % fails) rather than the scale to better than about ±0.05."""
    options = {**study.HEADLINE_DEFAULTS, "disturbance_scale": study.PAPER_BASELINE_SCALE, "random_phases": True}
    assert options["duration_s"] == 20.0
    peaks = np.array([study.headline_run("encoder", seed, options)["stabilization_error_urad"]["peak_after_settle"]
                      for seed in (1, 2, 3)]) * 1e-6
    paper = 1.2 * DEG
    print(f"\nencoder-only peaks at scale {study.PAPER_BASELINE_SCALE}: {np.round(peaks * 1e3, 2)} mrad, "
          f"mean {peaks.mean() / DEG:.3f} deg (paper 2: 1.2 deg)")
    assert abs(peaks.mean() - paper) < 0.10 * paper
    assert np.all(np.abs(peaks - paper) < 0.20 * paper)


@pytest.mark.parametrize("args, named", [
    (["rq", "--engine", "graph", "--seeds", "1"], "engine graph is not available"),
    (["headline", "--engine", "graph", "--seeds", "1", "--random-phases"], "random_phases"),
    (["headline", "--seeds", "one"], "--seeds"),
])
def test_cli_refuses_what_it_cannot_run_naming_it(args, named, capsys):
    with pytest.raises(SystemExit) as exc:
        study.main(args)
    assert exc.value.code == 2 and named in capsys.readouterr().err
