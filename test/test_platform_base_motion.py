"""A moving base in the four-gimbal plant (VehicleConfig.platform_base_motion): the outer
members' rates against numerical differentiation of the gimbal chain, the flag's default
keeps the static plant's numbers, and paper 5's moored ship through the servo."""
import math

import numpy as np
import pytest

from gimbal_kinematics.maths.four_gimbal import dcm_br, dcm_pq, dcm_rp, outer_member_rates
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, rotation_vector_from_dcm
from gimbal_sim.experiments.navigation import run_navigation
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore


def _rate_in_body(C_of_t, t, h=1e-6):
    """ω resolved in the moving frame from C_ib(t) (body to inertial): C_ibᵀ Ċ_ib = [ω×]."""
    dC = rotation_vector_from_dcm(C_of_t(t).T @ C_of_t(t + h)) / h
    return dC


def test_outer_member_rates_match_the_differentiated_chain():
    w_b = np.array([0.03, -0.02, 0.05])
    ang0 = np.array([0.4, 0.05, -0.1, 0.2])  # a, q, p, r
    rates = np.array([0.02, -0.01, 0.015, 0.03])

    def C_ib(t):
        return dcm_from_rotation_vector(w_b * t)

    def ang(t):
        return ang0 + rates * t

    C_ir = lambda t: C_ib(t) @ dcm_br(ang(t)[3])
    C_ip = lambda t: C_ir(t) @ dcm_rp(ang(t)[2])
    C_iq = lambda t: C_ip(t) @ dcm_pq(ang(t)[1])
    expect_a = _rate_in_body(C_iq, 0.0)[2]   # inner-roll gimbal about q-z
    expect_q = _rate_in_body(C_ip, 0.0)[0]   # pitch gimbal about p-x
    expect_p = _rate_in_body(C_ir, 0.0)[1]   # outer-roll gimbal about r-y
    expect_r = w_b[0]                        # base about b-x
    got = outer_member_rates(w_b, ang0, rates)
    assert got == pytest.approx((expect_a, expect_q, expect_p, expect_r), abs=1e-8)


def test_on_a_static_base_only_the_outer_joints_motion_torques_the_inner_ones():
    """Static base, constant earth rate: the outer roll (its outer member is the base) steps
    exactly as without base motion; the inner gimbals feel the outer joints' accelerations,
    a small coupling (< 1 % of their motion here)."""
    runs = []
    for flag in (False, True):
        core = VehicleCore(VehicleConfig(profile="static", profile_params={"lat_deg": 40.0},
                                         plant="four_gimbal_platform", duration_s=0.5, platform_base_motion=flag))
        for _ in range(500):
            core.step((0.5, -0.3, 0.2, 0.1))
        runs.append(np.array(core.truth().joint_position))
    assert runs[1][3] == runs[0][3]
    assert runs[1][:3] == pytest.approx(runs[0][:3], rel=0.01)
    assert not np.array_equal(runs[1][:3], runs[0][:3])


def test_the_servo_stabilises_the_platform_on_the_moored_ship():
    """Paper 5's ship (roll 5°, pitch 3°, heading 3°) at 400 Hz (loops at 10 Hz): every
    gimbal moves, the platform stays within arc-seconds of level after the start and the
    outer roll keeps the inner roll near null; a 5 Hz servo (0.125 Hz loops) cannot."""
    m = run_navigation(20.0, 1, rotate=True, rate_hz=400.0, ship=True, record_every_s=1.0)
    assert m["gimbal_lock_events"] == 0 and m["held_commands"] == 0
    assert m["control_rms_arcsec"] < 10.0
    assert m["inner_roll_null_max_arcsec"] < 600.0
    slow = run_navigation(20.0, 1, rotate=True, rate_hz=5.0, ship=True, record_every_s=1.0)
    assert slow["control_rms_arcsec"] > 100.0 * m["control_rms_arcsec"]
