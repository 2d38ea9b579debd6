"""Paper 3's platform INS chain as one compiled block loop: ``vehicle_dynamics`` (the
four-gimbal platform, on a static base or a moving one), ``sensor_models`` (its IMU and resolvers),
``platform_navigator`` and ``platform_servo``, the node set of ``rotational_ins_*``.

The cores are built from the nodes' parameter values exactly as :mod:`.core_loop` builds
them; their states are then packed into arrays and :func:`platform_block` steps N lockstep
steps at a time, in the Python loop's order (truth k → resolvers, IMU → navigator → servo
→ plant step k → k+1), calling the per-sample kernels: the plant's RK4 substeps
(``world.plant.platform_kernels``), the stable element's truth
(``gimbal_kinematics.maths.platform_kernels``), the sensor models (``world.sensors.sensor_kernels``),
the navigator (``gimbal_estimators.navigator_kernels``) and the servo
(``gimbal_control.servo_kernels``). Each sensor's normals are drawn per block from its own
seeded stream in the order its model takes them, so a seed gives the Python loop's numbers.
A moving host's truth (Euler angles, ω_ib^b, f_b) is computed per block by the profile's
kernel in the vehicle core's operation order (``world.plant.profile_kernels.host_truth_rows``),
and with ``platform_base_motion`` its torques −J ω̇_A into the loops by
``world.plant.platform_kernels.base_torques``, as the vehicle core computes them. With the
navigator on the servo's φz, each IMU step's servo leaves φz of the next on the navigator's
joint sample (``~/modulation_next``), which the navigator takes at that step.

Recorded, the block hands back each step's outputs (:data:`OUT_COLUMNS`) and
:mod:`.compiled_platform_record` serialises what each node publishes at the steps the
scenario's record list and rates keep, with the nodes' own serialisation functions.
"""
from __future__ import annotations

import math
import time
from array import array

import numpy as np
from numba import njit

from gimbal_control import servo_kernels as sk
from gimbal_estimators import navigator_kernels as nk
from gimbal_kinematics.maths.platform_kernels import platform_truth

from .loop_plan import CoreLoopResult, node_values
from .compiled_platform_record import ChainRecorder
from .compiled_platform_setup import (
    C_BASE_MOTION, C_CONTROLLED, C_DT, C_DTG, C_DTG_ARW, C_DTG_EVERY, C_DTG_IMAX, C_DTG_PICK, C_DTG_SCALE,
    C_FOLLOWS, C_FROM_SERVO, C_IMU_EVERY, C_JOINT, C_MAX_AGE_NS, C_N, C_QUASI, C_RATE, C_RES_CYCLIC, C_RES_EVERY,
    C_RES_GATE_STEPS, C_RES_GATE_TIME, C_RES_HARMONIC, C_RES_NOISE, C_RES_PHASES, C_RES_QUANTUM, C_SUBSTEPS, J_CMD,
    J_HAS, J_HAS_CMD, J_NAV_LAST, J_NAV_T0, J_NEXT_PHI, J_NEXT_RATE, J_NEXT_T, J_RATE, J_T_NS, J_THETA, N_OUT,
    PlatformChain, build_chain, chain_values,
)
from ..world.plant.platform_kernels import P_KT, P_VMAX, base_torques, platform_step, saturate
from ..world.plant.profile_kernels import host_truth_rows
from ..world.sensors.dtg_kernels import S_HAS_Q, S_I, dtg_update
from ..world.sensors.sensor_kernels import R_FIXED, R_GM, R_RRW, cyclic_error, encoder_step, inertial_step

#: steps per block: the normals and (recorded) the output rows of one block in memory
BLOCK_STEPS = 16384


def matches(scenario) -> bool:
    """Whether this runner steps ``scenario`` (:func:`.compiled_platform_setup.chain_values`)."""
    return chain_values(node_values(scenario)) is not None


@njit(cache=True)
def _navigator_node(c, ns, nq, joint, t_ns, res_due, ra, rr, imu_due, f) -> bool:
    """``platform_navigator``'s step (``core.platform_stages.platform_navigator_node_stage``):
    the azimuth joint of the step's resolver sample, or the servo's φz made for this step,
    extrapolated to the IMU sample; True when the navigator took a sample."""
    if c[C_FROM_SERVO] != 0.0:
        if imu_due and joint[J_NEXT_T] == t_ns:
            joint[J_HAS], joint[J_T_NS], joint[J_THETA], joint[J_RATE] = 1.0, t_ns, joint[J_NEXT_PHI], joint[J_NEXT_RATE]
    elif res_due:
        j = int(c[C_JOINT])
        joint[J_HAS], joint[J_T_NS], joint[J_THETA], joint[J_RATE] = 1.0, t_ns, ra[j], rr[j]
    if not imu_due:
        return False
    if joint[J_HAS] == 0.0:
        return False
    age = t_ns - joint[J_T_NS]
    if not (0.0 <= age <= c[C_MAX_AGE_NS]):
        return False
    theta = joint[J_THETA] + joint[J_RATE] * age * 1e-9 if age != 0.0 else joint[J_THETA]
    if not (math.isfinite(f[0]) and math.isfinite(f[1]) and math.isfinite(f[2]) and math.isfinite(theta)):
        return False
    first = math.isnan(joint[J_NAV_LAST])
    if first:
        joint[J_NAV_T0] = t_ns
    dt = 0.0 if first else (t_ns - joint[J_NAV_LAST]) * 1e-9
    joint[J_NAV_LAST] = t_ns
    nk.navigator_step(ns, nq, first, dt, (t_ns - joint[J_NAV_T0]) * 1e-9, f[0], f[1], f[2], theta)
    joint[J_HAS_CMD] = 1.0
    joint[J_CMD], joint[J_CMD + 1], joint[J_CMD + 2] = ns[nk.N_CMD_N], ns[nk.N_CMD_E], ns[nk.N_CMD_D]
    return True


@njit(cache=True)
def _servo_node(c, ss, sp, pid_s, pid_g, joint, t, k, res_due, ra, imu_due, w, pk, dtg_s) -> int:
    """``platform_servo``'s step k (``core.platform_stages.platform_servo_node_stage``): the
    resolvers, the navigator's command, then the tick (-2: none this step) at the node's step
    time k / rate, on the gyro triad's sample or on the DTGs' pickoffs ``pk`` (its torquer
    currents then held in ``dtg_s``)."""
    if res_due:
        sk.servo_resolvers(ss, t, ra[0], ra[1], ra[2], ra[3])
    if c[C_FOLLOWS] != 0.0 and imu_due and joint[J_HAS_CMD] != 0.0:
        sk.servo_command(ss, t, joint[J_CMD], joint[J_CMD + 1], joint[J_CMD + 2])
    tick = -2
    if c[C_DTG] != 0.0:
        if k % int(c[C_DTG_EVERY]) == 0:
            tick, ix, iy, iz = sk.servo_tick_pickoff(ss, sp, pid_s, pid_g, k / c[C_RATE], -pk[0], -pk[1], -pk[3],
                                                     c[C_DTG_SCALE], c[C_DTG_IMAX])
            if tick != sk.TICK_NONE:
                dtg_s[S_I], dtg_s[S_I + 1], dtg_s[S_I + 2] = ix, iy, iz
    elif imu_due:
        tick = sk.servo_tick(ss, sp, pid_s, pid_g, k / c[C_RATE], w[0], w[1], w[2])
    if imu_due and c[C_FROM_SERVO] != 0.0:  # ~/modulation_next: φz of the next IMU step, stamped with it
        k_next = k + int(c[C_IMU_EVERY])
        joint[J_NEXT_T] = np.rint(k_next * 1e9 / c[C_RATE])
        joint[J_NEXT_PHI], joint[J_NEXT_RATE] = sk.servo_modulation(ss, sp, k_next / c[C_RATE])
    return tick


@njit(cache=True)
def _truth(x, pp, host, angles, rates, wt, ft, qt, out_row) -> None:
    """The step's stable-element truth (ω_s into ``wt``, f_s into ``ft``, q_ns into ``qt``) from
    the plant state; with an output row, the joint states and q_ns into it too."""
    for a in range(4):
        angles[a], rates[a] = x[a, 0], x[a, 1]
    q, w, f = platform_truth(host[0:3], angles, rates, host[3:6], host[6:9])
    wt[0], wt[1], wt[2] = w
    ft[0], ft[1], ft[2] = f
    qt[0], qt[1], qt[2], qt[3] = q
    if out_row.shape[0] > 0:
        for a in range(4):
            out_row[a], out_row[4 + a], out_row[8 + a] = x[a, 0], x[a, 1], x[a, 2] * pp[a, P_KT]
        out_row[12], out_row[13], out_row[14], out_row[15] = q
        out_row[16], out_row[17], out_row[18] = w
        out_row[19], out_row[20], out_row[21] = f


@njit(cache=True)
def _record_row(row, ra, rr, fm, wm, ns, joint, nav_out, ss, tick, ticks, acc, gyr, pk, dtg_s) -> None:
    for a in range(4):
        row[22 + a], row[26 + a] = ra[a], rr[a]
    for a in range(3):
        row[30 + a], row[33 + a] = fm[a], wm[a]
    row[36], row[37] = 1.0 if nav_out else 0.0, ns[nk.N_ACCEPTED]
    for a in range(6):
        row[38 + a] = ns[nk.N_LAT + a]
    row[44], row[45], row[46], row[47] = joint[J_CMD], joint[J_CMD + 1], joint[J_CMD + 2], joint[J_HAS_CMD]
    row[48], row[49] = ns[nk.N_PSI], ns[nk.N_TORQUING]
    row[50], row[51] = tick, ticks
    for a in range(4):
        row[52 + a], row[56 + a] = ss[sk.S_V0 + a], ss[sk.S_G0 + a]
    row[60], row[61] = ss[sk.S_PHI], ss[sk.S_PHI_RATE]
    row[68], row[69] = joint[J_NEXT_PHI], joint[J_NEXT_RATE]
    for a in range(3):
        row[62 + a] = acc[R_FIXED, a] + acc[R_GM, a] + acc[R_RRW, a]
        row[65 + a] = gyr[R_FIXED, a] + gyr[R_GM, a] + gyr[R_RRW, a]
        row[74 + a] = dtg_s[S_I + a]
    for a in range(4):
        row[70 + a] = pk[a]


@njit(cache=True)
def platform_block(k0, k1, stamps, c, host, x, pp, rstate, rz, acc, acc_k, acc_c, az, gyr, gyr_k, gyr_c, gz, ns,
                   nq, joint, ss, sp, pid_s, pid_g, counts, base_last, dtg_s, dtg_g, dtg_m, dtg_qe, dz, out) -> None:
    """Steps k0 … k1−1 of the chain (module docstring); ``stamps`` their stamps [ns] (as
    floats), ``host`` the host's truth (euler, ω_ib^b, f_b) of each step (k1 − k0, 9), or of
    all (1, 9) when static, ``base_last`` the base torques' state (has one, ω_A a, q, p, r),
    ``rz``/``az``/``gz``/``dz`` the resolvers', accelerometers', gyros' and DTGs' normals of
    the block (row per sample), ``counts`` (servo ticks, rows of normals used: resolver, IMU,
    DTG), ``dtg_*`` the DTG pair (:mod:`..world.sensors.dtg_kernels`; unused without it),
    ``out`` (k1 − k0, :data:`N_OUT`) the steps' outputs, or (0, N_OUT) when not recorded."""
    angles, rates, ra, rr = np.empty(4), np.empty(4), np.zeros(4), np.zeros(4)
    fm, wm, volts, torques = np.zeros(3), np.zeros(3), np.zeros(4), np.zeros(4)
    wt, ft, qt, pk = np.zeros(3), np.zeros(3), np.zeros(4), np.zeros(4)
    empty, cyc = np.empty(0), np.empty(4)
    res_every, imu_every, n = int(c[C_RES_EVERY]), int(c[C_IMU_EVERY]), int(c[C_N])
    for k in range(k0, k1):
        t_ns = stamps[k - k0]
        row = out[k - k0] if out.shape[0] > 0 else empty
        h = host[k - k0] if host.shape[0] > 1 else host[0]
        _truth(x, pp, h, angles, rates, wt, ft, qt, row)
        res_due, imu_due = k % res_every == 0, k % imu_every == 0
        if res_due:
            read = angles
            if c[C_RES_CYCLIC] > 0.0:
                cyclic_error(angles, 4, c[C_RES_CYCLIC], c[C_RES_HARMONIC], c[C_RES_PHASES:C_RES_PHASES + 4], cyc)
                read = cyc
            encoder_step(rstate, 4, read, c[C_RES_QUANTUM], c[C_RES_NOISE], int(c[C_RES_GATE_STEPS]),
                         c[C_RES_GATE_TIME], rz[int(counts[1])], ra, rr)
            counts[1] += 1.0
        if imu_due:
            inertial_step(ft, acc, acc_k, acc_c, az[int(counts[2])], False, fm)
            inertial_step(wt, gyr, gyr_k, gyr_c, gz[int(counts[2])], False, wm)
            counts[2] += 1.0
        if c[C_DTG] != 0.0:
            zd = empty
            if dtg_s[S_HAS_Q] != 0.0:
                zd = dz[int(counts[3])]
                counts[3] += 1.0
            dtg_update(dtg_s, dtg_g, dtg_m, dtg_qe, qt, ft, c[C_DT], c[C_DTG_ARW], c[C_DTG_PICK], zd, pk)
        nav_out = _navigator_node(c, ns, nq, joint, t_ns, res_due, ra, rr, imu_due, fm)
        tick = _servo_node(c, ss, sp, pid_s, pid_g, joint, t_ns * 1e-9, k, res_due, ra, imu_due, wm, pk, dtg_s)
        if tick >= 0:
            counts[0] += 1.0
        if row.shape[0] > 0:
            _record_row(row, ra, rr, fm, wm, ns, joint, nav_out, ss, tick, counts[0], acc, gyr, pk, dtg_s)
        if k < n:
            for a in range(4):
                v = ss[sk.S_V0 + a] if c[C_CONTROLLED] != 0.0 else 0.0
                volts[a] = saturate(v, pp[a, P_VMAX])
            if c[C_BASE_MOTION] != 0.0:
                base_torques(h[3], h[4], h[5], x, base_last, pp, c[C_DT], torques)
            platform_step(x, volts, torques, c[C_DT], int(c[C_SUBSTEPS]), c[C_QUASI] != 0.0, pp)


def _multiples(k0: int, k1: int, every: int) -> int:
    """How many multiples of ``every`` lie in [k0, k1)."""
    return (k1 + every - 1) // every - (k0 + every - 1) // every


def _block_normals(chain: PlatformChain, k0: int, k1: int) -> tuple:
    """The block's normals: one take per due sample, from each model's own stream."""
    res = _multiples(k0, k1, chain.res_every)
    imu = _multiples(k0, k1, chain.imu_every)
    rz = chain.res_stream.take_block(4, res) if chain.res_noise > 0.0 \
        else np.zeros((res, 4))
    az = chain.acc_stream.take_block(chain.acc_need, imu) if chain.acc_need else np.zeros((imu, 1))
    gz = chain.gyr_stream.take_block(chain.gyr_need, imu) if chain.gyr_need else np.zeros((imu, 1))
    _, rng, need = chain.dtg
    steps = k1 - max(k0, 1)  # the pair draws from its second step on
    dz = rng.standard_normal((steps, need)) if need and steps > 0 else np.zeros((max(steps, 0), 1))
    return rz, az, gz, dz


def run(scenario, record=None, chain: PlatformChain | None = None) -> CoreLoopResult:
    """Step ``scenario``'s chain (module docstring); ``record`` (an
    :class:`.recording.EngineBag` or any ``record(node, messages)``) gets the nodes' messages.
    ``chain``: the scenario's chain already built (:func:`build_chain`), to read its final
    state after the run."""
    chain = build_chain(scenario) if chain is None else chain
    recorder = None if record is None else ChainRecorder(chain, record)
    n = chain.n_steps
    counts = np.zeros(4)
    c0 = time.process_time()
    t0 = time.perf_counter()
    for k0 in range(0, n + 1, BLOCK_STEPS):
        k1 = min(n + 1, k0 + BLOCK_STEPS)
        ks = np.arange(k0, k1)
        stamps = np.rint(ks * 1e9 / chain.rate_hz)
        rz, az, gz, dz = _block_normals(chain, k0, k1)
        counts[1] = counts[2] = counts[3] = 0.0
        out = np.empty((k1 - k0, N_OUT)) if recorder is not None else np.empty((0, N_OUT))
        host = chain.host.reshape(1, 9)
        if chain.moving is not None:
            host = np.empty((k1 - k0, 9))
            host_truth_rows(*chain.moving, k0, k1, chain.dt, *chain.env, host)
        platform_block(k0, k1, stamps, chain.config, host, chain.x, chain.plant_params, chain.res_state, rz,
                       chain.acc, chain.acc_k, chain.acc_c, az, chain.gyr, chain.gyr_k, chain.gyr_c, gz, chain.nav_state,
                       chain.nav_params, chain.joint, chain.servo_state, chain.servo_params, chain.pid_state,
                       chain.pid_gains, counts, chain.base_last, *chain.dtg[0], dz, out)
        if recorder is not None:
            recorder.block(k0, stamps.astype(np.int64), out, host)
    wall = time.perf_counter() - t0
    return CoreLoopResult(n, n * chain.dt, wall, time.process_time() - c0, array("d"), None)
