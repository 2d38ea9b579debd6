"""The engine's compiled runner for paper 1's sighting chain: ``vehicle_dynamics`` with the
two-axis gimbal, ``sensor_models`` with the INS, gimbal gyro and encoders, and optionally
``los_rate_controller`` (rate mode) and ``gyro_bias_ekf`` (sighting_land_vehicle,
los_stabilization, sim_open_loop, ...), stepped by :func:`.sighting_kernels.run_block` in
blocks of :data:`BLOCK` steps with no Python per step.

The cores are built as :mod:`.core_stages` builds them (from the nodes' parameter values), so
their constructors make the same init draws; their state is then copied into arrays the
kernels step. Each sensor's noise is drawn in blocks from its own stream
(``NormalStream.take_block``), the normals each sample would take, in the same order, so a
seed gives the same numbers as :func:`.core_loop.run_stages` with the cores' stages
(``test_compiled_sighting``).

:func:`matches` says whether a scenario's nodes (``core_loop.node_values``) are such a chain
in lockstep: gyro and encoders at every step, the INS every D steps, with the EKF's queued
gyro samples never waiting past its ``max_sync_wait_s``; :func:`run` runs it.
"""
from __future__ import annotations

import math
import time
from typing import Any, Callable

import numpy as np

from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_control.los_rate_kernels import controller_arrays
from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS

from . import sighting_kernels as sk
from .block_bag import BlockRecorder, BlockSource
from gimbal_control.wire import torque_command_messages
from gimbal_estimators.wire import ekf_messages
from gimbal_kinematics.maths.frames import GIMBAL_ENCODER_JOINTS
from gimbal_kinematics.maths.rotations import quat_canonical, quat_from_euler321

from ..nodes.wire import noise_covariances, sensor_messages, truth_messages
from ..world.sensor_suite import EncoderSample, GimbalGyroSample, InsSample, SensorSuite, SensorSuiteConfig
from ..world.vehicle import VehicleConfig, VehicleCore, VehicleTruth

#: Steps per compiled block (the noise of a block is drawn before it).
BLOCK = 8192
SENSORS = {"ins", "gimbal_gyro", "encoders"}


def _by_exe(values: dict[str, tuple[str, dict[str, Any]]]) -> dict[str, list[dict[str, Any]]]:
    out: dict[str, list[dict[str, Any]]] = {}
    for exe, v in values.values():
        out.setdefault(exe, []).append(v)
    return out


def matches(values: dict[str, tuple[str, dict[str, Any]]]) -> bool:
    """Whether the nodes (name -> (executable, parameter values)) are the chain this runner
    compiles (module docstring)."""
    nodes = _by_exe(values)
    if not set(nodes) <= {"vehicle_dynamics", "sensor_models", "los_rate_controller", "gyro_bias_ekf"} \
            or any(len(v) != 1 for v in nodes.values()) or "sensor_models" not in nodes:
        return False
    veh, sen = nodes["vehicle_dynamics"][0], nodes["sensor_models"][0]
    if veh["plant"] != "two_axis_gimbal" or veh.get("gimbal_actuator", "torque") != "torque" \
            or set(sen["sensors"]) != SENSORS \
            or any(v.get("timing", "lockstep") != "lockstep" for v in (veh, sen)):
        return False
    rate = veh["sim_rate_hz"]
    if sen["gimbal_gyro_rate_hz"] != rate or sen["encoder_rate_hz"] != rate:
        return False
    ctrl = nodes.get("los_rate_controller", [None])[0]
    if ctrl is not None and (ctrl["mode"] != "rate" or ctrl.get("timing", "lockstep") != "lockstep"):
        return False
    ekf = nodes.get("gyro_bias_ekf", [None])[0]
    if ekf is not None:
        ins_period = round(rate / sen["ins_rate_hz"]) / rate
        if ekf.get("timing", "lockstep") != "lockstep" or ins_period - 1.0 / rate >= 0.999 * ekf["max_sync_wait_s"]:
            return False
    return True


def _vehicle_arrays(vehicle: VehicleCore) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray]:
    """(state, parameters, profile arrays, gimbal kernel parameters) of a vehicle at step 0."""
    sim = vehicle._gimbal
    vs = np.zeros(sk.N_VEHICLE)
    vs[sk.V_X:sk.V_X + 4] = sim.x
    vs[sk.V_BASE:sk.V_BASE + 9] = tuple(sim.base)
    vs[sk.V_QNB:sk.V_QNB + 4] = vehicle._q_nb
    vs[sk.V_HOST:sk.V_HOST + 22] = tuple(sim.host)
    vs[sk.V_DELTA:sk.V_DELTA + 3] = vehicle._delta
    w = tuple(float(v) for v in sim.env.omega_in_n)
    lim = sim.dynamics.saturate((math.inf, math.inf))
    vg = np.array([sim.dt, sim._t0, float(sim.env.gravity_m_s2), *w, *lim, *vehicle._q_earth])
    return vs, vg, tuple(sim.profile.packed), sim.dynamics.kernel_params


def _ekf_arrays(ekf: GyroBiasEkf, ins_dec: int) -> tuple:
    """(ef, eg, P, A_cov, P_keep, Pb0, queue) of a fresh EKF (:mod:`.sighting_kernels` layout)."""
    n = ekf.n_states
    ef = np.zeros(sk.N_EKF)
    ef[sk.F_QW] = 1.0
    ef[sk.F_T_GYRO] = ef[sk.F_T_COV] = math.nan
    ef[sk.F_CA], ef[sk.F_CT] = 1.0, 1.0
    p = ekf.params
    eg = np.zeros(sk.N_EKF_PARAMS)
    eg[sk.G_WX:sk.G_WX + 3] = ekf._win
    eg[sk.G_GATE], eg[sk.G_ENC_VAR], eg[sk.G_FLOOR_VAR] = ekf._gate, ekf._enc_var, ekf._floor_var
    eg[sk.G_TAU_E], eg[sk.G_COV_PERIOD], eg[sk.G_MAX_GAP] = (p.ins_attitude_tau_s, p.covariance_period_s,
                                                           p.max_gyro_gap_s)
    eg[sk.G_MAX_GATED] = p.max_consecutive_gated
    eg[sk.G_N_PSD:sk.G_N_PSD + 3], eg[sk.G_QB_PSD:sk.G_QB_PSD + 3] = ekf._n_psd, ekf._qb_psd
    eg[sk.G_PE_VAR:sk.G_PE_VAR + 3] = ekf._pe_var
    return (ef, eg, np.zeros((n, n)), np.zeros((3, 3)), np.zeros((3, 3)), np.array(ekf._Pb0, dtype=float),
            np.zeros((ins_dec, 6)))


def _cores(values: dict[str, tuple[str, dict[str, Any]]]) -> tuple:
    """(vehicle, sensor suite, controller or None, EKF or None), built as the stages build them."""
    nodes = _by_exe(values)
    v = nodes["vehicle_dynamics"][0]
    vehicle = VehicleCore(VehicleConfig.from_values(v), GIMBAL_MODELS[v["gimbal_model"]])
    suite = SensorSuite(SensorSuiteConfig.from_values(nodes["sensor_models"][0]))
    ctrl = ekf = None
    if "los_rate_controller" in nodes:  # rate mode, no operator publishing: the shaper stays zero
        ctrl = LosRateController(LosRateControllerParams.from_values(nodes["los_rate_controller"][0]))
    if "gyro_bias_ekf" in nodes:
        ekf = GyroBiasEkf(GyroBiasEkfParams.from_values(nodes["gyro_bias_ekf"][0]))
    return vehicle, suite, ctrl, ekf, v["controlled"]


def _sensor_arrays(suite: SensorSuite) -> tuple:
    """The kernels' arrays of the suite's INS, gimbal gyro and encoders, and each one's
    (normal stream, normals per sample)."""
    att = suite.ins._attitude
    ins_att = (att.state.copy(), att.coef.copy(), att.order.copy())
    ins_gyro, ins_need = _inertial_arrays(suite.ins.gyro)
    gyro, gyro_need = _inertial_arrays(suite.gimbal_gyro)
    e = suite.encoders
    enc = (e._state.copy(), np.array([e.quantum_rad, e._noise, e._gate_steps, e.gate_time_s]))
    streams = ((att._normals, att.n_normals), (suite.ins.gyro._normals, ins_need),
               (suite.gimbal_gyro._normals, gyro_need),
               (suite.encoders._normals, suite.encoders.n_axes if suite.encoders._noise > 0.0 else 0))
    return ins_att, ins_gyro, gyro, enc, streams


def _inertial_arrays(model) -> tuple[tuple, int]:
    """Copies of an inertial model's kernel arrays (rows, K, constants) and its normals per sample."""
    return (model.rows.copy(), model.K.copy(), model.constants.copy()), model._need


def run(values: dict[str, tuple[str, dict[str, Any]]], keep_commands: bool = False,
        record: Callable[[str, list], None] | None = None) -> tuple:
    """Run the chain (:func:`matches` must hold): (steps, simulated s, wall s, CPU s, the applied
    command of every step 0 … n as tuples when ``keep_commands``, else None); ``record``
    (:class:`.recording.EngineBag`) gets every node's messages (:class:`_Publisher`)."""
    vehicle, suite, ctrl, ekf, controlled = _cores(values)
    n, rate = vehicle.config.n_steps, vehicle.config.sim_rate_hz
    ins_dec = suite._dec["ins_rate_hz"]
    vs, vg, profile, gp = _vehicle_arrays(vehicle)
    ins_att, ins_gyro, gyro, enc, streams = _sensor_arrays(suite)
    ekf_arrays = _ekf_arrays(ekf if ekf is not None else GyroBiasEkf(), ins_dec)
    ctrl_arrays = controller_arrays(ctrl if ctrl is not None else LosRateController())
    kept = []
    publish = _Publisher(values, vehicle, suite, record) if record is not None else None
    rec = np.empty((BLOCK if publish is not None else 0, sk.N_REC))
    c0, t0 = time.process_time(), time.perf_counter()
    for k in range(0, n + 1, BLOCK):
        k1 = min(k + BLOCK, n + 1)
        m_ins = len(range(-(-k // ins_dec) * ins_dec, k1, ins_dec))
        (att, a), (insg, b), (gyr, c), (en, d) = streams
        stamps = np.rint(np.arange(k, k1) * 1e9 / rate).astype(np.int64)
        commands = np.empty((k1 - k, 2))
        sk.run_block(k, k1, n, stamps, rate, vs, vg, profile, gp, ins_dec, ins_att, att.take_block(a, m_ins),
                     ins_gyro, insg.take_block(b, m_ins), gyro, gyr.take_block(c, k1 - k), enc,
                     en.take_block(d, k1 - k), ekf_arrays, ekf is not None, ctrl_arrays, ctrl is not None,
                     controlled, commands, rec, publish is not None)
        if publish is not None:
            publish(k, stamps, rec, ins_dec)
        if keep_commands:
            kept.extend(map(tuple, commands.tolist()))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return n, n * vehicle.config.dt, wall, cpu, kept if keep_commands else None


class _Publisher:
    """What each node of the chain publishes at each step of a block, from the block's record
    rows (:data:`.sighting_kernels.N_REC`), made by the nodes' own serialisation functions in
    the stages' order (:mod:`.core_stages`): truth, sensors, EKF output, torque command; each
    function call a :class:`.block_bag.BlockSource`, the block written at once
    (:class:`.block_bag.BlockRecorder`)."""

    def __init__(self, values, vehicle: VehicleCore, suite: SensorSuite, record) -> None:
        names = {exe: name for name, (exe, _) in values.items()}
        v = values[names["vehicle_dynamics"]][1]
        self.position_every, site = v["position_truth_every_steps"], vehicle.profile.site
        cov = noise_covariances(suite.config)
        veh, sen = names["vehicle_dynamics"], names["sensor_models"]
        ekf, ctrl = names.get("gyro_bias_ekf"), names.get("los_rate_controller")
        sources = [(veh, lambda t, r: truth_messages(t, _truth(t, r), "two_axis_gimbal")),
                   (veh, lambda t, r: truth_messages(t, _truth(t, r), "two_axis_gimbal", site)),
                   (sen, lambda t, r: sensor_messages(t, _ins(t, r), cov)),
                   (sen, lambda t, r: sensor_messages(t, GimbalGyroSample(t * 1e-9, r[sk.R_GYRO], r[sk.R_GYRO + 1],
                                                                          tuple(r[sk.R_GBIAS:sk.R_GBIAS + 2])), cov)),
                   (sen, lambda t, r: sensor_messages(t, EncoderSample(t * 1e-9, GIMBAL_ENCODER_JOINTS,
                                                                       tuple(r[sk.R_ENC:sk.R_ENC + 3]),
                                                                       tuple(r[sk.R_ENCR:sk.R_ENCR + 3])), cov))]
        self.has_ekf = ekf is not None
        if ekf is not None:
            sources += [(ekf, lambda t, r: _ekf(t, r, True)), (ekf, lambda t, r: _ekf(t, r, False))]
        if ctrl is not None:
            sources.append((ctrl, lambda t, r: torque_command_messages(t, (r[sk.R_CMD], r[sk.R_CMD + 1]))))
        self.sources = [BlockSource(node, fn, sk.N_REC, _ins_quat if i == 2 else None)
                        for i, (node, fn) in enumerate(sources)]
        self.record = BlockRecorder(record, self.sources)

    def __call__(self, k0: int, stamps: np.ndarray, rec: np.ndarray, ins_dec: int) -> None:
        """Record the steps k0 … k0 + len(stamps) - 1 (rows of ``rec``)."""
        k = np.arange(k0, k0 + len(stamps))
        rows = rec[:len(stamps)]
        due = k % self.position_every == 0 if self.position_every else np.zeros(len(k), dtype=bool)
        masks = [~due, due, k % ins_dec == 0, None, None]
        if self.has_ekf:
            out, has_w = rows[:, sk.R_EKF] != 0.0, rows[:, sk.R_EKF_HAS_W] != 0.0
            masks += [out & has_w, out & ~has_w]
        self.record(stamps, rows, masks + [None] * (len(self.sources) - len(masks)))


def _truth(t_ns: int, r) -> VehicleTruth:
    """The vehicle's truth of a record row."""
    return VehicleTruth(0, t_ns * 1e-9, None, r[sk.R_QNB:sk.R_QNB + 4], tuple(r[sk.R_W:sk.R_W + 3]),
                        tuple(r[sk.R_FB:sk.R_FB + 3]), r[sk.R_DELTA:sk.R_DELTA + 3], GIMBAL_ENCODER_JOINTS,
                        tuple(r[sk.R_POS:sk.R_POS + 3]), tuple(r[sk.R_VEL:sk.R_VEL + 3]),
                        (0.0, *r[sk.R_EFF:sk.R_EFF + 2]), r[sk.R_QNM:sk.R_QNM + 4], tuple(r[sk.R_WM:sk.R_WM + 3]),
                        tuple(r[sk.R_FM:sk.R_FM + 3]))


def _ins(t_ns: int, r) -> InsSample:
    return InsSample(t_ns * 1e-9, tuple(r[sk.R_INS_E:sk.R_INS_E + 3]), tuple(r[sk.R_INS_W:sk.R_INS_W + 3]),
                     tuple(r[sk.R_INS_B:sk.R_INS_B + 3]))


def _ins_quat(r) -> tuple:
    """The INS message's orientation, as ``sensor_messages`` computes it."""
    return quat_canonical(quat_from_euler321(*r[sk.R_INS_E:sk.R_INS_E + 3]))


def _ekf(t_ns: int, r, has_w: bool):
    """The EKF's output messages of a record row (with or without its corrected rate)."""
    c = r[sk.R_EKF_COV:sk.R_EKF_COV + 9]
    return ekf_messages(int(round(t_ns * 1e-9 * 1e9)), r[sk.R_EKF_B:sk.R_EKF_B + 3], r[sk.R_EKF_SIG:sk.R_EKF_SIG + 3],
                        r[sk.R_EKF_Q:sk.R_EKF_Q + 4], (c[0:3], c[3:6], c[6:9]),
                        r[sk.R_EKF_W:sk.R_EKF_W + 3] if has_w else None)
