"""gimbal_sim.tools.bandwidth: its signal measures against closed forms, and the paper-loop
scenario's timing (the paper's bandwidth)."""
import math

import numpy as np
import pytest

from gimbal_control.loop_design import margins_full
from gimbal_sim.core.core_loop import node_values
from gimbal_sim.graph.scenario import load
from gimbal_sim.tools.bandwidth import jitter_rms, los_error_components, main, sinusoid_amplitude


def test_sinusoid_amplitude_recovers_a_mode_beside_offset_trend_and_another_mode():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 4.0, 1.0 / 4000.0)
    x = (2e-6 * np.sin(101.0 * t + 0.4) + 5e-7 * np.cos(258.0 * t) + 3e-5 + 1e-6 * t
         + 1e-8 * rng.standard_normal(t.size))
    assert sinusoid_amplitude(t, x, 101.0) == pytest.approx(2e-6, rel=2e-3)
    assert sinusoid_amplitude(t, x, 258.0) == pytest.approx(5e-7, rel=1e-2)


def test_jitter_rms_of_a_sinusoid_on_offset_and_trend_is_amplitude_over_root_two():
    t = np.arange(0.0, 10.0, 1e-3)  # whole periods of 5 Hz: the trend fit does not leak
    err = np.column_stack((4e-6 * np.sin(2 * math.pi * 5.0 * t) + 1e-4 + 2e-5 * t, np.full_like(t, -3e-4)))
    assert jitter_rms(t, err) == pytest.approx(4e-6 / math.sqrt(2.0), rel=1e-3)


def test_error_components_are_the_small_angles_across_the_initial_los():
    u0 = np.array([0.6, 0.8, 0.0])
    a = np.cross(u0, [0, 0, 1.0]) / np.linalg.norm(np.cross(u0, [0, 0, 1.0]))
    los = np.array([u0, math.cos(1e-4) * u0 + math.sin(1e-4) * a])
    comp = los_error_components(np.zeros(2), los)
    assert comp[1] == pytest.approx([1e-4, 0.0], abs=1e-12)


def test_paper_loop_scenario_samples_gyro_and_encoders_at_its_loop_rate():
    base, paper = load("sighting_land_vehicle"), load("sighting_land_vehicle_100hz")
    values = {name: v for name, (_, v) in node_values(paper).items()}
    assert paper.sim_rate_hz == 4000.0
    assert values["sensor_models"]["gimbal_gyro_rate_hz"] == values["sensor_models"]["encoder_rate_hz"] == 4000.0
    assert (values["los_rate_controller"]["omega_n_hz"], values["los_rate_controller"]["zeta"]) == (100.0, 0.8)
    assert set(paper.variants) == set(base.variants)
    # the paper's loop at 4 kHz keeps the default's margins: ω_n T is the same (25/1000 = 100/4000)
    m_paper, m_base = margins_full(4000.0, 100.0), margins_full(1000.0, 25.0)
    assert m_paper.stable and m_paper.phase_margin_deg == pytest.approx(m_base.phase_margin_deg, abs=1.0)


def test_cli_refuses_a_duration_without_a_settled_window(capsys):
    assert main(["--duration", "0.5"]) == 2
    assert "--duration" in capsys.readouterr().err
