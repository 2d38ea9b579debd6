"""The compiled block loop of paper 1's sighting chain (numba ``njit``): the vehicle (two-axis
gimbal on its motion profile), ``sensor_models`` (INS, gimbal gyro, encoders),
``gyro_bias_ekf`` and ``los_rate_controller`` stepped over a block of lockstep steps, each
step in :mod:`.core_loop`'s order (truth k → sensors k → EKF k → command k → step k → k+1).

Each core's per-sample maths is its kernel: :func:`..world.plant.sighting_plant_kernels.gimbal_step`,
:mod:`..world.sensors.sensor_kernels`, :mod:`gimbal_estimators.gyro_bias_ekf_kernels`,
:mod:`gimbal_control.los_rate_kernels`. What this module adds is what the nodes' messages
and input policies do between them in lockstep: the truth the vehicle publishes, the INS
attitude as a reader of its quaternion gets it, and the EKF's multi-rate grouping
(:class:`gimbal_kinematics.timing.sync.RateSync`), which in lockstep (gyro and encoders every step,
the INS every D steps) is: gyro samples wait for the next INS sample; when it comes they are
integrated in order with the encoder angles of their own stamp and the INS rates
interpolated linearly between its last two samples; the gyro sample of the INS stamp
follows, then the update at that stamp.

The arrays (state vectors with named indices, noise blocks) are made and read by
:mod:`.compiled_sighting`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_control.los_rate_kernels import S_BIAS_Q, S_BIAS_R, S_CMD_Q, S_CMD_R, los_rate_step
from gimbal_estimators.gyro_bias_ekf_kernels import (
    BIAS, BIAS_0, INS_ERROR_0, N_STATES_INS, PSI_0, SINGULAR_COS, a_matrix, align_cov, joseph_update3, measurement,
    measurement_cov, mechanize, propagate,
)
from gimbal_kinematics.gimbal.host_kernels import inertial_rates
from gimbal_kinematics.maths.quat_kernels import (
    euler321_from_quat, quat_canonical, quat_conj, quat_from_euler321, quat_from_rotation_vector, quat_mul,
    rotation_vector_from_quat,
)

from ..world.plant.sighting_plant_kernels import gimbal_step, inner_gimbal_truth
from ..world.sensors.sensor_kernels import R_FIXED, R_GM, R_RRW, encoder_step, inertial_step, ins_attitude

# EKF scalar state (``ef``)
(F_QX, F_QY, F_QZ, F_QW, F_ALIGNED, F_B0, F_B1, F_B2, F_E0, F_E1, F_E2, F_T_GYRO, F_WP, F_WQ, F_WR, F_HAS_W,
 F_CA, F_SA, F_CT, F_ST, F_P_LAST, F_T_COV, F_CONSEC, F_KEEP, F_UPDATES, F_GATED, F_REALIGN, F_SINGULAR,
 F_INS_T0, F_INS_P0, F_INS_Q0, F_INS_R0, F_INS_T1, F_INS_P1, F_INS_Q1, F_INS_R1, F_HAS_INS, F_QUEUED) = range(38)
N_EKF = 38
# EKF parameters (``eg``): ω_in^n, gate, σ² enc, σ² floor, τ_e, covariance period, max gyro gap,
# max consecutive gated, then n_psd (3), qb_psd (3), pe_var (3)
(G_WX, G_WY, G_WZ, G_GATE, G_ENC_VAR, G_FLOOR_VAR, G_TAU_E, G_COV_PERIOD, G_MAX_GAP, G_MAX_GATED,
 G_N_PSD, G_QB_PSD, G_PE_VAR) = (*range(10), 10, 13, 16)
N_EKF_PARAMS = 19
# vehicle state (``vs``): x (4), base (9), q_nb (4), applied torque (2), host (22), δ of the last step (3)
V_X, V_BASE, V_QNB, V_TAU, V_HOST, V_DELTA = 0, 4, 13, 17, 19, 41
N_VEHICLE = 44
# vehicle parameters (``vg``): dt, t0, gravity, ω_in^n (3), torque limits (2), exp([ω_in dt×]) (4)
VG_DT, VG_T0, VG_G, VG_WX, VG_WY, VG_WZ, VG_LIM_A, VG_LIM_E, VG_QE = range(9)
N_VEHICLE_PARAMS = 12
# a recorded step's row: the vehicle's truth (q_nb, ω_ib^b, f_b, δ, joint angles, rates, applied
# torques, q_nm, ω_im^m, f_m), the gyro (q_m, r_m, true bias), encoders (angles, rates), the INS
# (Euler angles, rates, true bias), the controller's command, the EKF's output (flag, bias, σ,
# q_nm, P_ψψ, corrected-rate flag and rate)
(R_QNB, R_W, R_FB, R_DELTA, R_POS, R_VEL, R_EFF, R_QNM, R_WM, R_FM, R_GYRO, R_GBIAS, R_ENC, R_ENCR, R_INS_E,
 R_INS_W, R_INS_B, R_CMD, R_EKF, R_EKF_B, R_EKF_SIG, R_EKF_Q, R_EKF_COV, R_EKF_HAS_W, R_EKF_W) = (
    0, 4, 7, 10, 13, 16, 19, 21, 25, 28, 31, 33, 35, 38, 41, 44, 47, 50, 52, 53, 56, 59, 63, 72, 73)
N_REC = 76


@njit(cache=True)
def vehicle_truth(vs: np.ndarray, vg: np.ndarray) -> tuple:
    """(euler as the sensors read it from the Imu quaternion, ω_ib^b, f_b, joint angles (ψt, ψm,
    θm), joint rates, the inner gimbal's (q_nm, ω_im^m, f_m)) of the current step
    (``VehicleCore.truth``: f_b = a_b − C_bn (0, 0, g))."""
    h = vs[V_HOST:V_HOST + 22]
    x = vs[V_X:V_X + 4]
    cr, sr = math.cos(h[1]), math.sin(h[1])
    cp, sp = math.cos(h[2]), math.sin(h[2])
    w = inertial_rates(h[10], h[11], h[12], h[13], h[14], h[15], h[3], vg[VG_WX], vg[VG_WY], vg[VG_WZ],
                       cr, sr, cp, sp)
    g = vg[VG_G]
    f = (h[19] - (-sp) * g, h[20] - (sr * cp) * g, h[21] - (cr * cp) * g)
    q = (vs[V_QNB], vs[V_QNB + 1], vs[V_QNB + 2], vs[V_QNB + 3])
    euler = euler321_from_quat(q[0], q[1], q[2], q[3])
    pos = (h[16], x[0], x[1])
    vel = (h[17], x[2], x[3])
    w3 = (w[0], w[1], w[2])
    return euler, w3, f, pos, vel, inner_gimbal_truth(q, pos, vel, w3, f)


@njit(cache=True)
def vehicle_step(vs: np.ndarray, vg: np.ndarray, i: int, ta: float, te: float, lines: np.ndarray,
                 terms: np.ndarray, starts: np.ndarray, p: np.ndarray) -> None:
    """Step ``i`` → i + 1 under the torques (τ_a, τ_e), saturated (``GimbalSimulator.step``)."""
    la, le = vg[VG_LIM_A], vg[VG_LIM_E]
    ta = la if ta > la else -la if ta < -la else ta
    te = le if te > le else -le if te < -le else te
    dt, t0 = vg[VG_DT], vg[VG_T0]
    t = t0 + i * dt
    x = vs[V_X:V_X + 4]
    b = vs[V_BASE:V_BASE + 9]
    x1, host1, base1 = gimbal_step((x[0], x[1], x[2], x[3]), ta, te, (b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7],
                                   b[8]), t + 0.5 * dt, t0 + (i + 1) * dt, dt, lines, terms, starts, vg[VG_G],
                                   vg[VG_WX], vg[VG_WY], vg[VG_WZ], p)
    for j in range(4):
        vs[V_X + j] = x1[j]
    for j in range(9):
        vs[V_BASE + j] = base1[j]
    for j in range(22):
        vs[V_HOST + j] = host1[j]
    q = quat_canonical(quat_from_euler321(host1[1], host1[2], host1[3]))
    q0 = (vs[V_QNB], vs[V_QNB + 1], vs[V_QNB + 2], vs[V_QNB + 3])
    qe = (vg[VG_QE], vg[VG_QE + 1], vg[VG_QE + 2], vg[VG_QE + 3])
    # δ = log(C_nb(t_k)ᵀ exp([ω_in dt×]) C_nb(t_k+1))
    d = rotation_vector_from_quat(*quat_mul(quat_mul(quat_conj(q0), qe), q))
    for j in range(3):
        vs[V_DELTA + j] = d[j]
    for j in range(4):
        vs[V_QNB + j] = q[j]
    vs[V_TAU], vs[V_TAU + 1] = ta, te


@njit(cache=True)
def _ins_rates_at(ef: np.ndarray, t: float) -> tuple:
    """The INS rates at ``t``: held beyond the last two samples, linear between them."""
    if ef[F_HAS_INS] < 2.0 or t >= ef[F_INS_T1]:
        return ef[F_INS_P1], ef[F_INS_Q1], ef[F_INS_R1]
    t0, t1 = ef[F_INS_T0], ef[F_INS_T1]
    if t <= t0:
        return ef[F_INS_P0], ef[F_INS_Q0], ef[F_INS_R0]
    f = (t - t0) / (t1 - t0)
    return (ef[F_INS_P0] + f * (ef[F_INS_P1] - ef[F_INS_P0]), ef[F_INS_Q0] + f * (ef[F_INS_Q1] - ef[F_INS_Q0]),
            ef[F_INS_R0] + f * (ef[F_INS_R1] - ef[F_INS_R0]))


@njit(cache=True)
def _propagate_cov(ef: np.ndarray, eg: np.ndarray, P: np.ndarray, A_cov: np.ndarray) -> None:
    """P over [t_cov, t_gyro] (``GyroBiasEkf._propagate_covariance``)."""
    T = ef[F_T_GYRO] - ef[F_T_COV]
    if T <= 0.0:
        return
    A1 = a_matrix((ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW]), ef[F_CT], ef[F_ST])
    w = eg[G_WX:G_WX + 3]
    P_new, f_e = propagate(P, 0.5 * (A_cov + A1), T, w, eg[G_N_PSD:G_N_PSD + 3], eg[G_QB_PSD:G_QB_PSD + 3],
                           eg[G_PE_VAR:G_PE_VAR + 3], eg[G_TAU_E])
    P[:, :] = P_new
    if P.shape[0] == N_STATES_INS:
        for i in range(3):
            ef[F_E0 + i] = ef[F_E0 + i] * f_e
    ef[F_T_COV] = ef[F_T_GYRO]
    A_cov[:, :] = A1


@njit(cache=True)
def _realign(ef: np.ndarray, P: np.ndarray, P_keep: np.ndarray) -> None:
    """Re-align from the next measurement, keeping the bias covariance."""
    ef[F_REALIGN] += 1.0
    P_keep[:, :] = P[BIAS, BIAS]
    ef[F_KEEP] = 1.0
    ef[F_ALIGNED] = 0.0
    ef[F_T_COV] = math.nan
    ef[F_CONSEC] = 0.0


@njit(cache=True)
def ekf_integrate(ef: np.ndarray, eg: np.ndarray, P: np.ndarray, A_cov: np.ndarray, P_keep: np.ndarray, t: float,
                  q_m: float, r_m: float, a0: float, a1: float, a2: float) -> None:
    """Mechanize to the gyro sample at ``t`` with the joint angles of its stamp
    (``GyroBiasEkf.integrate`` and ``_omega``)."""
    rates = _ins_rates_at(ef, t)
    t_prev = ef[F_T_GYRO]
    ef[F_T_GYRO] = t
    az = a0 + a1
    ca, sa, ct, st = math.cos(az), math.sin(az), math.cos(a2), math.sin(a2)
    ef[F_CA], ef[F_SA], ef[F_CT], ef[F_ST] = ca, sa, ct, st
    q = q_m - ef[F_B1]
    r = r_m - ef[F_B2]
    if abs(ct) < SINGULAR_COS:
        ef[F_SINGULAR] += 1.0
        p = ef[F_P_LAST]
    else:
        p = (ca * rates[0] + sa * rates[1] - ef[F_B0] - st * r) / ct
    ef[F_P_LAST] = p
    had_w = ef[F_HAS_W] != 0.0
    w0 = (ef[F_WP], ef[F_WQ], ef[F_WR])
    ef[F_WP], ef[F_WQ], ef[F_WR], ef[F_HAS_W] = p, q, r, 1.0
    if ef[F_ALIGNED] == 0.0 or math.isnan(t_prev):
        return
    dt = t - t_prev
    if dt > eg[G_MAX_GAP]:
        _realign(ef, P, P_keep)
        return
    qn = mechanize((ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW]), w0 if had_w else (p, q, r), (p, q, r), dt,
                   (eg[G_WX], eg[G_WY], eg[G_WZ]))
    ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW] = qn
    if t - ef[F_T_COV] >= eg[G_COV_PERIOD]:
        _propagate_cov(ef, eg, P, A_cov)


@njit(cache=True)
def _align(ef: np.ndarray, P: np.ndarray, A_cov: np.ndarray, P_keep: np.ndarray, Pb0: np.ndarray, eg: np.ndarray,
           q_meas: tuple, Je: np.ndarray, R: np.ndarray) -> None:
    """Ĉ = C_meas and its covariance (``GyroBiasEkf._align``)."""
    n = P.shape[0]
    ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW] = q_meas
    ef[F_ALIGNED] = 1.0
    P[:, :] = align_cov(n, R, Je, eg[G_PE_VAR:G_PE_VAR + 3], P_keep if ef[F_KEEP] != 0.0 else Pb0)
    ef[F_KEEP] = 0.0
    if n == N_STATES_INS:
        ef[F_E0] = ef[F_E1] = ef[F_E2] = 0.0
    ef[F_T_COV] = ef[F_T_GYRO]
    A_cov[:, :] = a_matrix(q_meas, ef[F_CT], ef[F_ST])
    ef[F_CONSEC] = 0.0


@njit(cache=True)
def _apply(ef: np.ndarray, dx: np.ndarray) -> None:
    """Ĉ ← exp([ψ̂×]) Ĉ, b̂ ← b̂ + δb̂, ê ← ê⁺, and the next trapezoid's start corrected."""
    q = quat_mul(quat_from_rotation_vector(dx[PSI_0], dx[PSI_0 + 1], dx[PSI_0 + 2]),
                 (ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW]))
    ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW] = q
    for i in range(3):
        ef[F_B0 + i] = ef[F_B0 + i] + dx[BIAS_0 + i]
    if dx.shape[0] == N_STATES_INS:
        for i in range(3):
            ef[F_E0 + i] = dx[INS_ERROR_0 + i]
    if ef[F_HAS_W] != 0.0:
        ct, st = ef[F_CT], ef[F_ST]
        ct = ct if abs(ct) >= SINGULAR_COS else math.copysign(SINGULAR_COS, ct)
        db_x, db_q, db_r = dx[BIAS_0], dx[BIAS_0 + 1], dx[BIAS_0 + 2]
        ef[F_WP] = ef[F_WP] - (db_x - st * db_r) / ct
        ef[F_WQ] = ef[F_WQ] - db_q
        ef[F_WR] = ef[F_WR] - db_r


@njit(cache=True)
def ekf_update(ef: np.ndarray, eg: np.ndarray, P: np.ndarray, A_cov: np.ndarray, P_keep: np.ndarray,
               Pb0: np.ndarray, euler: tuple, angles: tuple) -> None:
    """The update with the INS attitude of the gyro stamp just integrated (``GyroBiasEkf.fuse``)."""
    n = P.shape[0]
    q_meas, Je, Jenc = measurement(euler, angles)
    R = measurement_cov(Jenc, Je, eg[G_ENC_VAR], eg[G_FLOOR_VAR], eg[G_PE_VAR:G_PE_VAR + 3], n == 6)
    if ef[F_ALIGNED] == 0.0:
        _align(ef, P, A_cov, P_keep, Pb0, eg, q_meas, Je, R)
        return
    _propagate_cov(ef, eg, P, A_cov)
    hx, hy, hz, hw = ef[F_QX], ef[F_QY], ef[F_QZ], ef[F_QW]
    mx, my, mz, mw = q_meas
    z = np.array(rotation_vector_from_quat(-mw * hx + mx * hw - my * hz + mz * hy,
                                           -mw * hy + mx * hz + my * hw - mz * hx,
                                           -mw * hz - mx * hy + my * hx + mz * hw,
                                           mw * hw + mx * hx + my * hy + mz * hz))
    H = np.zeros((3, n))
    x = np.zeros(n)
    for i in range(3):
        H[i, PSI_0 + i] = 1.0
        if n == N_STATES_INS:
            x[INS_ERROR_0 + i] = ef[F_E0 + i]
            for j in range(3):
                H[i, INS_ERROR_0 + j] = Je[i, j]
    accepted, x_up, P_up, _, _ = joseph_update3(x, P, z, H, R, eg[G_GATE])
    if accepted:
        ef[F_CONSEC] = 0.0
        ef[F_UPDATES] += 1.0
        P[:, :] = P_up
        _apply(ef, x_up)
    else:
        ef[F_GATED] += 1.0
        ef[F_CONSEC] += 1.0
        if ef[F_CONSEC] >= eg[G_MAX_GATED]:
            _realign(ef, P, P_keep)


@njit(cache=True)
def ekf_step(ef: np.ndarray, eg: np.ndarray, P: np.ndarray, A_cov: np.ndarray, P_keep: np.ndarray, Pb0: np.ndarray,
             queue: np.ndarray, t: float, ins_due: bool, ins_rates: np.ndarray, ins_euler: tuple, q_m: float,
             r_m: float, angles: np.ndarray) -> bool:
    """The EKF's lockstep step at ``t`` (module docstring): encoders, then the INS (its rates
    release the queued gyro samples), then the gyro; True when an update (or alignment) was made."""
    if ins_due:
        if ef[F_HAS_INS] >= 1.0:
            ef[F_INS_T0], ef[F_INS_P0], ef[F_INS_Q0], ef[F_INS_R0] = (ef[F_INS_T1], ef[F_INS_P1], ef[F_INS_Q1],
                                                                      ef[F_INS_R1])
        ef[F_INS_T1], ef[F_INS_P1], ef[F_INS_Q1], ef[F_INS_R1] = t, ins_rates[0], ins_rates[1], ins_rates[2]
        ef[F_HAS_INS] = min(ef[F_HAS_INS] + 1.0, 2.0)
        for i in range(int(ef[F_QUEUED])):
            g = queue[i]
            ekf_integrate(ef, eg, P, A_cov, P_keep, g[0], g[1], g[2], g[3], g[4], g[5])
        ef[F_QUEUED] = 0.0
    if ef[F_HAS_INS] == 0.0 or ef[F_INS_T1] < t:
        i = int(ef[F_QUEUED])
        queue[i, 0], queue[i, 1], queue[i, 2] = t, q_m, r_m
        queue[i, 3], queue[i, 4], queue[i, 5] = angles[0], angles[1], angles[2]
        ef[F_QUEUED] = i + 1.0
        return False
    ekf_integrate(ef, eg, P, A_cov, P_keep, t, q_m, r_m, angles[0], angles[1], angles[2])
    if not ins_due:
        return False
    ekf_update(ef, eg, P, A_cov, P_keep, Pb0, ins_euler, (angles[0], angles[1], angles[2]))
    return True


@njit(cache=True, nogil=True)  # the bag's chunk writer compresses meanwhile
def run_block(k0: int, k1: int, n_steps: int, stamps_ns: np.ndarray, rate_hz: float, vs: np.ndarray,
              vg: np.ndarray, profile: tuple, gp: np.ndarray, ins_dec: int, ins_att: tuple, z_att: np.ndarray,
              ins_gyro: tuple, z_ins: np.ndarray, gyro: tuple, z_gyro: np.ndarray, enc: tuple, z_enc: np.ndarray,
              ekf: tuple, has_ekf: bool, ctrl: tuple, has_ctrl: bool, controlled: bool, commands: np.ndarray,
              rec: np.ndarray, recording: bool) -> None:
    """Lockstep steps k0 … k1 − 1 (the vehicle steps while k < ``n_steps``), each step's
    applied command into ``commands`` (k1 − k0, 2) and, ``recording``, what its nodes publish
    into ``rec`` (k1 − k0, N_REC); noise rows: one per INS sample of the block (``z_att``,
    ``z_ins``), one per step (``z_gyro``, ``z_enc``)."""
    lines, terms, starts = profile
    e_att, coef_att, order_att = ins_att
    ef, eg, P, A_cov, P_keep, Pb0, queue = ekf
    cs, cg = ctrl
    omega_b, ins_rates, qr, qr_m = np.empty(3), np.zeros(3), np.empty(2), np.empty(2)
    pos, pos_m, rate_m = np.empty(3), np.empty(3), np.empty(3)
    ins_euler = em = (0.0, 0.0, 0.0)
    ia = 0
    for k in range(k0, k1):
        j = k - k0
        t = stamps_ns[j] * 1e-9
        euler, w, f, p, v, inner = vehicle_truth(vs, vg)
        ins_due = k % ins_dec == 0
        if ins_due:
            em = ins_attitude(e_att, coef_att, order_att, z_att[ia], euler[0], euler[1], euler[2])
            omega_b[0], omega_b[1], omega_b[2] = w
            inertial_step(omega_b, ins_gyro[0], ins_gyro[1], ins_gyro[2], z_ins[ia], False, ins_rates)
            ins_euler = euler321_from_quat(*quat_canonical(quat_from_euler321(em[0], em[1], em[2])))
            ia += 1
        qr[0], qr[1] = inner[1][1], inner[1][2]
        inertial_step(qr, gyro[0], gyro[1], gyro[2], z_gyro[j], False, qr_m)
        pos[0], pos[1], pos[2] = p
        encoder_step(enc[0], pos.shape[0], pos, enc[1][0], enc[1][1], int(enc[1][2]), enc[1][3], z_enc[j], pos_m, rate_m)
        updated = has_ekf and ekf_step(ef, eg, P, A_cov, P_keep, Pb0, queue, t, ins_due, ins_rates, ins_euler,
                                       qr_m[0], qr_m[1], pos_m)
        if recording:
            rec[j, R_EKF] = 0.0
            record_truth(rec[j], vs, w, f, p, v, inner)
            record_sensors(rec[j], ins_due, em, ins_rates, ins_gyro[0], qr_m, gyro[0], pos_m, rate_m)
            if updated:
                record_ekf(rec[j], ef, P)
        ta = te = 0.0
        if has_ctrl:
            if updated and math.isfinite(t) and math.isfinite(ef[F_B0]) and math.isfinite(ef[F_B1]) \
                    and math.isfinite(ef[F_B2]):  # the controller's set_bias_estimate
                cs[S_BIAS_Q], cs[S_BIAS_R] = ef[F_B1], ef[F_B2]
            ta, te = los_rate_step(cs, cg, k / rate_hz, qr_m[0], qr_m[1], pos_m[0], pos_m[1], pos_m[2], rate_m[0],
                                   rate_m[1], rate_m[2], ins_rates[0], ins_rates[1], ins_rates[2], cs[S_CMD_Q],
                                   cs[S_CMD_R])
        if recording:
            rec[j, R_CMD], rec[j, R_CMD + 1] = ta, te
        if not controlled:
            ta = te = 0.0
        commands[j, 0], commands[j, 1] = ta, te
        if k < n_steps:
            vehicle_step(vs, vg, k, ta, te, lines, terms, starts, gp)


@njit(cache=True)
def record_truth(r: np.ndarray, vs: np.ndarray, w: tuple, f: tuple, pos: tuple, vel: tuple, inner: tuple) -> None:
    """The vehicle's truth of the step (:func:`vehicle_truth`, the step's δ and applied
    torques) into the row ``r``."""
    q_nm, wm, fm = inner
    for i in range(3):
        r[R_W + i], r[R_FB + i], r[R_DELTA + i] = w[i], f[i], vs[V_DELTA + i]
        r[R_POS + i], r[R_VEL + i], r[R_WM + i], r[R_FM + i] = pos[i], vel[i], wm[i], fm[i]
    for i in range(4):
        r[R_QNB + i], r[R_QNM + i] = vs[V_QNB + i], q_nm[i]
    r[R_EFF], r[R_EFF + 1] = vs[V_TAU], vs[V_TAU + 1]


@njit(cache=True)
def record_ekf(r: np.ndarray, ef: np.ndarray, P: np.ndarray) -> None:
    """The EKF's output after an update into the row ``r`` (``GyroBiasEkf._output`` and its
    ``corrected_rate``)."""
    r[R_EKF] = 1.0
    for i in range(3):
        r[R_EKF_B + i] = ef[F_B0 + i]
        r[R_EKF_SIG + i] = math.sqrt(P[BIAS_0 + i, BIAS_0 + i])
        r[R_EKF_W + i] = ef[F_WP + i]
        for j in range(3):
            r[R_EKF_COV + 3 * i + j] = P[PSI_0 + i, PSI_0 + j]
    for i in range(4):
        r[R_EKF_Q + i] = ef[F_QX + i]
    r[R_EKF_HAS_W] = ef[F_HAS_W]


@njit(cache=True)
def record_sensors(r: np.ndarray, ins_due: bool, em: tuple, ins_rates: np.ndarray, ins_s: np.ndarray,
                   qr_m: np.ndarray, gyro_s: np.ndarray, pos_m: np.ndarray, rate_m: np.ndarray) -> None:
    """The sensors' samples of the step into the row ``r``, each true bias fixed + GM + random walk."""
    for i in range(2):
        r[R_GYRO + i] = qr_m[i]
        r[R_GBIAS + i] = gyro_s[R_FIXED, i] + gyro_s[R_GM, i] + gyro_s[R_RRW, i]
    for i in range(3):
        r[R_ENC + i], r[R_ENCR + i] = pos_m[i], rate_m[i]
        if ins_due:
            r[R_INS_E + i], r[R_INS_W + i] = em[i], ins_rates[i]
            r[R_INS_B + i] = ins_s[R_FIXED, i] + ins_s[R_GM, i] + ins_s[R_RRW, i]
