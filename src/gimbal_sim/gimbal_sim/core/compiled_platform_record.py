"""The platform chain's recording: each block's output rows turned into what each node
publishes, by the nodes' own serialisation functions, at the steps whose messages the bag keeps.

A node's messages of a step are made only when one of its topics that the scenario records
is published at that step and kept by the record rates (the bag's
:class:`..bag.record_rates.RecordRates` rule, followed ahead with the same state, so the bag
then keeps exactly those). A ``record`` that is not an :class:`.recording.EngineBag` gets
every node's messages at every step. Within a step the nodes come in the Python loop's
order (vehicle, sensors, navigator, servo), so the bag's messages are in the same order too.
"""
from __future__ import annotations

import numpy as np

from gimbal_control.platform_servo import ServoCommand
from gimbal_control.wire import platform_servo_messages
from gimbal_estimators.platform_navigator import NavigatorOutput
from gimbal_estimators.wire import navigator_messages
from gimbal_kinematics.maths.frames import DTG_PICKOFF_JOINTS, PLATFORM_JOINTS
from gimbal_kinematics.timing.stamps import step_stamp_ns

from .compiled_platform_setup import O
from .recording import EngineBag, resolve
from ..nodes.wire import noise_covariances, sensor_messages, truth_messages
from ..world.sensor_suite import DtgSample, PlatformImuSample, ResolverSample
from ..world.vehicle import host_quat, step_rotation

_TRUTH_EVERY = ("/truth/host/imu", "/truth/host/delta_angle", "/truth/platform/joint_states", "/truth/platform/imu",
                "/clock")
_TRUTH_FIX = ("/truth/host/fix", "/truth/host/velocity")
_RESOLVERS = ("/platform/resolvers",)
_IMU = ("/platform/imu", "/truth/platform/accel_bias", "/truth/platform/gyro_bias")
_DTG = ("/platform/dtg_pickoffs",)
_NAV_FIX = ("~/fix", "~/velocity", "~/odom")
_NAV_CMD = ("~/command_rate",)
_SERVO_EVERY = ("/platform/voltage_cmd",)
_SERVO_TORQUER = ("~/torquer_current",)
_SERVO_DIAG = ("~/control_error", "~/modulation")
_SERVO_NEXT = ("~/modulation_next",)
#: the nodes in the loop's order, by executable
_ORDER = ("vehicle_dynamics", "sensor_models", "platform_navigator", "platform_servo")


def _tuple(row: np.ndarray, a: int, b: int) -> tuple[float, ...]:
    return tuple(row[a:b].tolist())


class ChainRecorder:
    """``block(k0, stamps, out)``: record one block's steps (module docstring)."""

    def __init__(self, chain, record) -> None:
        self.O = O
        self.chain, self.record = chain, record
        self.bag = record if isinstance(record, EngineBag) else None
        self._next: dict[str, int] = {}
        v = chain.values
        self.position_every = v["vehicle_dynamics"]["position_truth_every_steps"]
        self.fix_every = v["platform_navigator"]["fix_every_samples"]
        self.diag_every = v["platform_servo"]["diagnostics_every_steps"]
        self.next_phi = v["platform_servo"]["modulation_next"]
        self.dtg = chain.suite.dtg is not None
        self._host: np.ndarray | None = None  # a moving host's rows of the block, and the last row before it
        self._host_before: np.ndarray | None = None
        self._k0 = 0
        self.frames = (v["platform_navigator"]["odom_frame_id"], v["platform_navigator"]["odom_child_frame_id"])
        self.cov = noise_covariances(chain.suite.config)

    def _kept(self, node: str, topics: tuple[str, ...], mask: np.ndarray, stamps: np.ndarray) -> np.ndarray:
        """Where any of ``node``'s ``topics`` published at ``mask`` is recorded and kept."""
        if self.bag is None:
            return mask
        need = np.zeros_like(mask)
        for topic in topics:
            name = resolve(node, topic, self.bag.remaps.get(node, {}))
            if self.bag.wanted is not None and name not in self.bag.wanted:
                continue
            period = self.bag.rates.period_ns.get(name)
            if period is None:
                need |= mask
                continue
            idx = np.flatnonzero(mask)
            st = stamps[idx]
            due = self._next.get(name)
            pos = 0 if due is None else int(np.searchsorted(st, due, "left"))
            while pos < len(st):
                need[idx[pos]] = True
                due = int(st[pos]) + period
                pos = int(np.searchsorted(st, due, "left"))
            if due is not None:
                self._next[name] = due
        return need

    def _masks(self, k0: int, stamps: np.ndarray, out: np.ndarray) -> dict[str, np.ndarray]:
        """executable -> the steps of the block whose messages are made."""
        O, ch, n = self.O, self.chain, len(stamps)
        ks = np.arange(k0, k0 + n)
        every = np.ones(n, dtype=bool)
        names = ch.names
        pos = (ks % self.position_every == 0) if self.position_every else np.zeros(n, dtype=bool)
        res, imu = ks % ch.res_every == 0, ks % ch.imu_every == 0
        fix = (out[:, O["nav_out"]] != 0.0) & ((out[:, O["accepted"]] - 1.0) % self.fix_every == 0.0)
        cmd = imu & (out[:, O["has_cmd"]] != 0.0)
        diag = (out[:, O["tick"]] >= 0.0) & ((out[:, O["ticks"]] - 1.0) % self.diag_every == 0.0)
        kept = self._kept
        on_dtg = every if self.dtg else np.zeros(n, dtype=bool)
        return {
            "vehicle_dynamics": kept(names["vehicle_dynamics"], _TRUTH_EVERY, every, stamps)
            | kept(names["vehicle_dynamics"], _TRUTH_FIX, pos, stamps),
            "sensor_models": kept(names["sensor_models"], _RESOLVERS, res, stamps)
            | kept(names["sensor_models"], _IMU, imu, stamps) | kept(names["sensor_models"], _DTG, on_dtg, stamps),
            "platform_navigator": kept(names["platform_navigator"], _NAV_FIX, fix, stamps)
            | kept(names["platform_navigator"], _NAV_CMD, cmd, stamps) | fix,  # odometry sees every fix
            "platform_servo": kept(names["platform_servo"], _SERVO_EVERY, every, stamps)
            | kept(names["platform_servo"], _SERVO_TORQUER, on_dtg, stamps)
            | kept(names["platform_servo"], _SERVO_DIAG, diag, stamps)
            | kept(names["platform_servo"], _SERVO_NEXT, imu & self.next_phi, stamps),
        }

    def block(self, k0: int, stamps: np.ndarray, out: np.ndarray, host: np.ndarray) -> None:
        """Record the block of steps k0 … k0 + len(stamps) − 1 from their output rows and the
        host's truth rows (one row: a static host)."""
        self._host, self._k0 = host, k0
        masks = self._masks(k0, stamps, out)
        steps = sorted((i, order) for order, exe in enumerate(_ORDER) for i in np.flatnonzero(masks[exe]).tolist())
        make = (self._vehicle, self._sensors, self._navigator, self._servo)
        for i, order in steps:
            make[order](k0 + i, int(stamps[i]), out[i])
        self._host_before = host[-1]

    def _vehicle(self, k: int, t_ns: int, row: np.ndarray) -> None:
        ch = self.chain
        base = ch.truth0 if k == 0 else ch.truth1
        if ch.moving is not None:
            base = self._moving_host(k, base)
        truth = base._replace(k=k, t=k * ch.dt, joint_position=_tuple(row, 0, 4), joint_velocity=_tuple(row, 4, 8),
                              joint_effort=_tuple(row, 8, 12), quat_nm=np.array(row[12:16]),
                              omega_im_m=_tuple(row, 16, 19), specific_force_m=_tuple(row, 19, 22))
        due = self.position_every and k % self.position_every == 0
        self.record(ch.names["vehicle_dynamics"], truth_messages(t_ns, truth, "four_gimbal_platform",
                                                                   ch.site if due else None))

    def _moving_host(self, k: int, base):
        """``base`` with a moving host's truth of step k: its row's Euler angles, ω_ib^b, f_b,
        the attitude and the rotation over the step from the row before (the vehicle core's)."""
        i = k - self._k0
        row = self._host[i].tolist()
        q1 = host_quat(*row[0:3])
        delta = (0.0, 0.0, 0.0)
        if k > 0:
            before = self._host[i - 1] if i > 0 else self._host_before
            delta = step_rotation(host_quat(*before[0:3].tolist()), self.chain.q_earth, q1)
        return base._replace(euler=tuple(row[0:3]), quat_nb=np.array(q1), omega_ib_b=tuple(row[3:6]),
                             specific_force_b=tuple(row[6:9]), delta_angle_b=np.array(delta))

    def _sensors(self, k: int, t_ns: int, row: np.ndarray) -> None:
        ch, name, t = self.chain, self.chain.names["sensor_models"], k * self.chain.dt
        if k % ch.res_every == 0:
            s = ResolverSample(t, PLATFORM_JOINTS, _tuple(row, 22, 26), _tuple(row, 26, 30))
            self.record(name, sensor_messages(t_ns, s, self.cov))
        if k % ch.imu_every == 0:
            ab, gb = self.O["ab0"], self.O["gb0"]
            s = PlatformImuSample(t, _tuple(row, 30, 33), _tuple(row, 33, 36), _tuple(row, ab, ab + 3),
                                  _tuple(row, gb, gb + 3))
            self.record(name, sensor_messages(t_ns, s, self.cov))
        if self.dtg:
            pk = self.O["pk0"]
            self.record(name, sensor_messages(t_ns, DtgSample(t, DTG_PICKOFF_JOINTS, _tuple(row, pk, pk + 4), ()),
                                              self.cov))

    def _navigator(self, k: int, t_ns: int, row: np.ndarray) -> None:
        O = self.O
        if k % self.chain.imu_every:
            return
        cmd = _tuple(row, O["cmd_n"], O["cmd_d"] + 1) if row[O["has_cmd"]] != 0.0 else None
        fix = odom = None
        if row[O["nav_out"]] != 0.0 and (row[O["accepted"]] - 1.0) % self.fix_every == 0.0:
            fix = NavigatorOutput(t_ns, _tuple(row, O["vn"], O["vd"] + 1), float(row[O["lat"]]), float(row[O["lon"]]),
                                  float(row[O["h"]]), cmd, float(row[O["psi"]]), bool(row[O["torquing"]]))
            odom = (*self.frames, *self.chain.odometry(fix))
        self.record(self.chain.names["platform_navigator"], navigator_messages(t_ns, fix, cmd, odom))

    def _servo(self, k: int, t_ns: int, row: np.ndarray) -> None:
        O = self.O
        volts = _tuple(row, O["v0"], O["v3"] + 1)
        out = None
        if row[O["tick"]] >= 0.0 and (row[O["ticks"]] - 1.0) % self.diag_every == 0.0:
            out = ServoCommand(k / self.chain.rate_hz, volts, _tuple(row, O["g0"], O["g3"] + 1), float(row[O["phi"]]),
                               float(row[O["phi_rate"]]), row[O["tick"]] == 0.0)
        nxt = None
        if self.next_phi and k % self.chain.imu_every == 0:
            nxt = (step_stamp_ns(k + self.chain.imu_every, self.chain.rate_hz), float(row[O["phin"]]),
                   float(row[O["phin_rate"]]))
        torquer = _tuple(row, O["tq0"], O["tq2"] + 1) if self.dtg else None
        self.record(self.chain.names["platform_servo"], platform_servo_messages(t_ns, volts, out, torquer, nxt))
