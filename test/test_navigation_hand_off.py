"""The alignment's hand-off to navigation through the no-ROS engine (plant, sensors, servo,
navigator; gimbal_sim.experiments.navigation): the misalignment handed over is
torqued out of the simulated platform within the pulse, and a handed-over drift estimate
enters the command. Truth: the plant's platform attitude; no sensor noise, ideal resolvers;
static base at 40° N, rotation off (φz ≡ 0, so the true azimuth must go to 0)."""
from __future__ import annotations

import math

import numpy as np

from gimbal_estimators.platform_navigator import HandOff
from gimbal_kinematics.maths.earth import OMEGA_IE, meridian_radius, normal_gravity
from gimbal_sim.experiments.navigation import HAND_OFF_RATE_HZ, PlatformStart, run_navigation
from gimbal_sim.experiments.platform_servo import alignment_setup
from gimbal_sim.world.sensors import AccelerometerParams, EncoderParams, GyroParams

ARCSEC = math.pi / (180.0 * 3600.0)
LAT = math.radians(40.0)
QUIET = {"accel": AccelerometerParams(), "resolver": EncoderParams(), "rotate": False, "record_every_s": 1.0}


def test_misalignment_handed_over_is_torqued_out_within_the_pulse():
    phi_arcsec = (20.0, -30.0, 1000.0)  # (δφE, δφN, δφU), paper 3 Table 2 sizes
    heading_deg, joints_deg = alignment_setup(phi_arcsec)
    hand_off = HandOff(LAT, 0.0, 0.0, misalignment_enu=tuple(v * ARCSEC for v in phi_arcsec))
    start = PlatformStart(heading_deg, joints_deg, hand_off, heading_deg)
    # at the hand-off's navigation rate (at 5 Hz the servo's loops ring on the pulse)
    s = run_navigation(31.0, 0, gyro=GyroParams(), start=start, rate_hz=HAND_OFF_RATE_HZ, **QUIET)["series"]
    tilt = s["tilt_en_rad"] / ARCSEC
    azimuth = s["azimuth_true_rad"] / ARCSEC
    # before: the plant holds the misalignment set through the gimbal angles (U = −azimuth)
    np.testing.assert_allclose(tilt[0], phi_arcsec[:2], atol=0.2)  # second order: δφU × tilt
    assert abs(azimuth[0] + phi_arcsec[2]) < 0.05
    # 20 s after the 10 s pulse: azimuth within 1 % of its initial size, tilts 1 % + the
    # east floor, the earth-rate coupling ω_N δφU T/2 during the pulse
    coupling = OMEGA_IE * math.cos(LAT) * phi_arcsec[2] * 10.0 / 2.0
    after = s["t"] >= 29.9
    assert np.max(np.abs(azimuth[after])) < 10.0, azimuth[after]
    assert np.max(np.abs(tilt[after, 0])) < 0.3 + coupling, tilt[after]
    assert np.max(np.abs(tilt[after, 1])) < 0.3, tilt[after]


def test_drift_estimate_handed_over_enters_the_command():
    """A north-axis gyro bias b makes the platform drift at −b about north; with the Schuler
    loop closed its tilt is −b sin(ω_s t)/ω_s. Handed over as the drift estimate (−b), it is
    compensated in the command and the tilt stays near zero."""
    b = math.radians(0.03) / 3600.0
    gyro = GyroParams(bias_deg_h=(0.03, 0.0, 0.0))
    site = HandOff(LAT, 0.0, 0.0)
    w_s = math.sqrt(normal_gravity(LAT, 0.0) / meridian_radius(LAT))
    tilts = {}
    for name, hand_off in (("none", site), ("compensated", site._replace(gyro_drift_s=(-b, 0.0, 0.0)))):
        s = run_navigation(600.0, 0, gyro=gyro, start=PlatformStart(hand_off=hand_off), **QUIET)["series"]
        tilts[name] = s["tilt_en_rad"][-1, 1]
        t_end = s["t"][-1]
    expected = -b * math.sin(w_s * t_end) / w_s
    assert abs(tilts["none"] - expected) < 0.05 * abs(expected), (tilts, expected)
    assert abs(tilts["compensated"]) < 0.02 * abs(expected), (tilts, expected)
