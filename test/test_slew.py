"""Slew and dead-man acceptance on paper 1's vehicle: the operator's step command of 5 °/s in
azimuth and 2 °/s in elevation through the controller's shaper (scenario ``sighting_slew`` on
the engine, its figures read back from the bag by the ``slew`` report).

References: the truth's inertial LOS rate (VehicleCore), against the command and against
the command minus the true gyro bias (what a rate loop closed on a biased gyro follows,
closed form); the dead-man deadline stamp + timeout + |v|/a of the shaper's docstring.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_control.operator_command import OperatorCommand, OperatorCommandParams
from gimbal_kinematics.timing.stamps import step_stamp_ns
from gimbal_sim.core.core_loop import core_plan, node_values, run_stages
from gimbal_sim.core.core_stages import controller_stage
from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.experiments.slew import scenario_values
from gimbal_sim.graph.scenario import load, variant
from gimbal_sim.reports.slew import slew_analysis
from gimbal_sim.world.operator_model import StepStick

AZ, EL = math.radians(5.0), math.radians(2.0)


def run_slew(mode: str, seed: int, options: dict, out) -> dict:
    """Scenario ``sighting_slew``'s run with the campaign's ``options`` on the engine, and the
    slew report's figures from its bag."""
    from dataclasses import replace

    duration, values = scenario_values(options)
    scenario = replace(variant(load("sighting_slew"), mode), seed=seed, duration_s=duration)
    for key, value in values:
        node, param = key.split(".")
        scenario.nodes[node]["params"][param] = value
    run_engine(scenario, out / f"{mode}_{seed}", compress=False)
    return slew_analysis(out / f"{mode}_{seed}")


@pytest.fixture(scope="module")
def slews(tmp_path_factory):
    short = {"hold_s": 1.0, "slew_s": 2.0}
    out = tmp_path_factory.mktemp("slew")
    return {mode: run_slew(mode, 1, short, out)["slew"] for mode in ("ekf_off", "ekf_on")}


def test_the_scripted_stick_commands_its_step_from_its_start_for_its_duration():
    stick = StepStick(1.0, 0.5, (0.1, -0.2))
    t0 = 5 * 10**9  # stamps from the first step, wherever the clock starts
    got = {dt: stick.step(t0 + dt) for dt in (0, 999_999_999, 10**9, 1_499_999_999, 15 * 10**8)}
    assert got == {0: (0.0, 0.0), 999_999_999: (0.0, 0.0), 10**9: (0.1, -0.2), 1_499_999_999: (0.1, -0.2),
                   15 * 10**8: (0.0, 0.0)}
    assert all(math.isnan(v) for v in stick.pointing_error())
    with pytest.raises(ValueError, match="step_rate_deg_s"):
        StepStick(0.0, 1.0, (0.1,))


def test_step_command_is_followed_within_2_percent_and_settles(slews):
    s = slews["ekf_on"]
    assert abs(s["az_error_pct"]) < 2.0 and abs(s["el_error_pct"]) < 2.0
    assert 0.0 < s["az_settling_time_s"] < 0.2 and 0.0 < s["el_settling_time_s"] < 0.2


def test_without_the_filter_the_loop_follows_the_command_minus_the_gyro_bias(slews):
    s = slews["ekf_off"]
    assert abs(s["az_error_vs_cmd_minus_bias_pct"]) < 0.3 and abs(s["el_error_vs_cmd_minus_bias_pct"]) < 0.3
    assert abs(s["el_error_pct"]) > 0.5  # the bias is visible: the check above is not trivially met


def test_deadman_stops_the_slew_at_the_timeout_plus_the_deceleration_and_counts_it():
    scenario = variant(load("sighting_land_vehicle"), "ekf_off")
    scenario = type(scenario)(**{**scenario.__dict__, "duration_s": 2.5})
    vehicle, controlled, stages = core_plan(scenario)
    values = next(v for exe, v in node_values(scenario).values() if exe == "los_rate_controller")
    op = OperatorCommand(OperatorCommandParams.from_values(values))
    core = LosRateController(LosRateControllerParams.from_values(values), operator=op)
    rate = scenario.sim_rate_hz
    last_cmd_k = 1000  # commands at 20 Hz from 0.5 s to 1.0 s, then the stick is let go

    def commander(bus) -> None:
        on = 500 <= bus.k <= last_cmd_k and bus.k % 50 == 0
        bus.operator = (step_stamp_ns(bus.k, rate), EL, AZ) if on else None

    rates = []
    stages[-1:] = [commander, controller_stage(core, rate)]
    run_stages(vehicle, stages, controlled=controlled,
               observer=lambda bus: rates.append((bus.t, *bus.truth.omega_im_m[1:], *bus.gyro.true_bias)))
    t, q, r, b_q, b_r = np.array(rates).T
    deadline = last_cmd_k / rate + op.params.timeout_s
    stop = deadline + AZ / op.max_accel  # the shaped command reaches zero here
    assert op.deadman_stops == 1 and op.holding
    assert op.last_stop_ns == pytest.approx(stop * 1e9, abs=1e3)
    moving = (t > 0.7) & (t < deadline)
    assert np.all(np.abs(r[moving] - AZ) < 0.05 * AZ)  # still slewing until the deadline
    # held again once the loop settles (~0.1 s, test above): the rate averaged over 0.1 s
    # (the vehicle's vibration is not the slew) is back to what a loop holding a biased gyro
    # still at zero leaves, −bias, within 2 % of the slew's
    smooth = lambda x: np.convolve(x, np.ones(100) / 100, mode="valid")  # noqa: E731
    held = t[99:] > stop + 0.2
    assert np.all(np.abs(smooth(r + b_r)[held]) < 0.02 * AZ) and np.all(np.abs(smooth(q + b_q)[held]) < 0.02 * EL)


def test_per_step_nees_averaged_over_seeds_against_its_band(tmp_path):
    """nees_per_step on seeded χ²(2) draws (a consistent filter: about 95 % of the steps inside
    χ²(2N)/N's band, binomial bounds) and on draws 1.6 times too large (an optimistic filter:
    above it as often as the closed form says); then on two short slews of the EKF, whose per-step NEES it combines."""
    from scipy.stats import chi2

    from gimbal_sim.experiments.slew import nees_per_step, summarize

    rng = np.random.default_rng(24)
    t = [round(0.01 * i, 9) for i in range(4000)]
    consistent = [{"t_s": t, "bias_nees": list(rng.chisquare(2, 4000))} for _ in range(5)]
    p = nees_per_step(consistent)
    assert p["band95"] == pytest.approx(list(chi2.ppf([0.025, 0.975], 10) / 5))
    assert p["inside"] == pytest.approx(0.95, abs=4.5 * math.sqrt(0.95 * 0.05 / 4000))
    assert p["above"] == pytest.approx(0.025, abs=0.012) and p["mean"] == pytest.approx(2.0, abs=0.05)
    optimistic = [{"t_s": t, "bias_nees": list(1.6 * np.array(s["bias_nees"]))} for s in consistent]
    above = chi2.sf(chi2.ppf(0.975, 10) / 1.6, 10)  # P(1.6·χ²(10) above the band's top): 0.236
    assert nees_per_step(optimistic)["above"] == pytest.approx(above, abs=4.5 * math.sqrt(above * (1 - above) / 4000))
    with pytest.raises(ValueError, match="time grid"):
        nees_per_step([consistent[0], {"t_s": t[1:], "bias_nees": consistent[1]["bias_nees"][1:]}])

    short = {"hold_s": 1.0, "slew_s": 0.5}
    runs = [(seed, run_slew("ekf_on", seed, short, tmp_path)) for seed in (1, 2)]
    series = [m["slew_nees"] for _, m in runs]
    assert series[0]["t_s"] == [round(0.01 * i, 9) for i in range(50)]  # each EKF output (100 Hz) of the slew
    assert all(v >= 0.0 and math.isfinite(v) for s in series for v in s["bias_nees"])
    p = nees_per_step(series)
    assert np.allclose(p["nees"], np.mean([s["bias_nees"] for s in series], axis=0), rtol=0.0, atol=0.0)
    assert "% of the steps inside its 95 % band" in summarize({"ekf_on": runs})
