"""``vehicle_dynamics`` node: owns ``/clock`` and steps the :class:`.vehicle.VehicleCore`.

Stepping is driven by events, never by timers (except in ``realtime`` timing, whose point is
the wall clock):

* ``controlled: true``, ``timing: lockstep`` (what scenarios use): after publishing the
  truth of step k, the node integrates k → k+1 only when the command stamped k arrives.
  The same inputs therefore give the same outputs, however slow any node is.
* ``controlled: false``: no controller; the node runs open loop at full speed, re-arming
  itself through a guard condition so other callbacks interleave.
* ``timing: realtime``: a wall-clock timer at the simulation rate times
  ``real_time_factor`` (below 1 on a loaded machine: the stamps stay sim time, so the
  free-timing nodes see the same data); a command that is late is replaced by the last
  one and counted. The command subscription then uses the
  free-timing input QoS (:func:`gimbal_kinematics.ros.node_io.input_qos`: best effort,
  volatile), so a free-timing controller (reliable, volatile) or a driver-like publisher
  matches it; the truth publishers stay reliable + transient-local, which every
  subscription matches (best effort or reliable, volatile or transient-local). A command
  stamped for an earlier step than the current one is not thrown away in realtime timing:
  the newest one is held for the next step (a real plant applies the newest command it
  has), and that step is still counted late.

Command interface (``command_interface``): ``graph`` (above: the stamp names the step) or
``ros2_control``, the joint-command contract of ``topic_based_ros2_control``: a JointState of
joint names and efforts on ``ros2_control_topic`` (reliable, volatile), stamped with the
sender's clock, which names no step. Each such command is applied from the plant's next step
on: in lockstep one command per step, in the order they arrive (the sender answers each
truth step with one command, as a ros2_control read/update/write cycle does), so the same
commands give the same run; in realtime timing the newest is held, as a motor driver holds
its last setpoint. A command before step 0 is ignored (counted).

Step 0 is published once every truth topic has at least ``wait_for_subscribers`` matched
subscriptions (and, when controlled, the command topic a publisher).

Readiness and flow control (``pace_topics``): a downstream node that must see every step
(sensor models, the recorder) publishes on a ``rosgraph_msgs/Clock`` progress topic the
time of the next step it needs, first once its own publishers are matched ("ready", step
0) and then as it works. The vehicle publishes step 0 only when every pace topic has
reported, and never runs more than ``pace_window_steps`` ahead of the slowest, so no reader
misses a step to discovery and an open-loop run at full speed loses nothing.
"""
from __future__ import annotations

import math
import sys
from collections import deque

from rclpy.node import Node
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix
from geometry_msgs.msg import Vector3Stamped

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_io import input_qos
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS, ROS2_CONTROL_QOS
from gimbal_kinematics.params import ros2_control_topic
from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.params import topic_counts
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.frames import GIMBAL_COMMAND_JOINTS, PLATFORM_JOINTS
from ..world.vehicle import VehicleConfig, VehicleCore, VehicleTruth
from .vehicle_dynamics_params import DESCRIPTION, PARAMS
from .wire import truth_messages


class VehicleDynamicsNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("vehicle_dynamics", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.config = VehicleConfig.from_values(values)
        self.core = VehicleCore(self.config, GIMBAL_MODELS[values["gimbal_model"]])
        self.controlled = values["controlled"]
        self.realtime = values["timing"] == "realtime"
        self.real_time_factor = float(values["real_time_factor"])
        self.exit_at_end = values["exit_at_end"]
        self.wait_for_subscribers = values["wait_for_subscribers"]
        self.done = Future()
        plant = self.config.plant
        self._command = (0.0,) * self.config.command_size
        self._command_k: int | None = None
        self._command_names = {"two_axis_gimbal": GIMBAL_COMMAND_JOINTS,
                               "four_gimbal_platform": PLATFORM_JOINTS}.get(plant, ())
        self.rejected_commands = 0   # NaN/inf, wrong size or names, stale or future stamps
        self.late_commands = 0       # realtime timing: step taken with the held command
        self._started = False
        self._open_loop_running = False

        self.pub_clock = self.create_publisher(Clock, "/clock", GRAPH_QOS)
        self.pub_host = self.create_publisher(Imu, "/truth/host/imu", GRAPH_QOS)
        self.pub_delta = self.create_publisher(Vector3Stamped, "/truth/host/delta_angle", GRAPH_QOS)
        self._truth_pubs = [self.pub_clock, self.pub_host, self.pub_delta]
        self.pub_joints = self.pub_plant_imu = None
        if plant != "host_only":
            prefix = "/truth/gimbal" if plant == "two_axis_gimbal" else "/truth/platform"
            self.pub_joints = self.create_publisher(JointState, f"{prefix}/joint_states", GRAPH_QOS)
            self.pub_plant_imu = self.create_publisher(Imu, f"{prefix}/imu", GRAPH_QOS)
            self._truth_pubs += [self.pub_joints, self.pub_plant_imu]
        # the host's true position and velocity, for a navigator's report (off by default: bags unchanged);
        # every motion profile holds the host at its site, so the velocity relative to the earth is zero
        self.position_every = values["position_truth_every_steps"]
        if self.position_every:
            self.pub_fix = self.create_publisher(NavSatFix, "/truth/host/fix", GRAPH_QOS)
            self.pub_velocity = self.create_publisher(Vector3Stamped, "/truth/host/velocity", GRAPH_QOS)
            self._truth_pubs += [self.pub_fix, self.pub_velocity]
        self.pace_window = values["pace_window_steps"]
        self._next_needed: dict[str, int | None] = {topic: None for topic in values["pace_topics"]}
        self._pace_subs = [self.create_subscription(Clock, topic, lambda data, t=topic: self._on_progress(t, data),
                                                    GRAPH_QOS, raw=True) for topic in self._next_needed]
        self.sub_cmd = None
        self.ros2_control = values["command_interface"] == "ros2_control"
        command_topic = ros2_control_topic(values) if self.ros2_control else ""
        self._queued: deque[tuple[float, ...] | None] = deque()  # ros2_control in lockstep: one per step
        if plant != "host_only" and (self.controlled or self.realtime):
            if self.ros2_control:
                topic, qos, on_command = command_topic, ROS2_CONTROL_QOS, self._on_ros2_control
            else:
                topic = "/gimbal/torque_cmd" if plant == "two_axis_gimbal" else "/platform/voltage_cmd"
                # realtime: the command comes from a free-timing controller (node_io's outputs are volatile)
                qos = input_qos("free") if self.realtime else GRAPH_QOS
                on_command = self._on_command
            self.sub_cmd = self.create_subscription(JointState, topic, on_command, qos, raw=True)
        self._needed = self._subscriber_counts(values["subscriber_counts"])
        # topic -> subscriptions the graph must show before step 0
        self._graph_needed = topic_counts(values["topic_subscriber_counts"], "topic_subscriber_counts")
        self._rearm = None  # open loop: zero-period timer that re-runs _open_loop_step (see there)
        self._startup_timer = self.create_timer(0.02, self._try_start)
        self._pub_by_topic = {p.topic_name: p for p in self._truth_pubs}

    # --- start-up handshake -------------------------------------------------------------
    def _subscriber_counts(self, entries: list[str]) -> dict:
        """Publisher -> matched subscriptions it needs before step 0."""
        by_topic = {p.topic_name: p for p in self._truth_pubs}
        needed = {p: self.wait_for_subscribers for p in self._truth_pubs}
        for topic, count in topic_counts(entries, "subscriber_counts", list(by_topic)).items():
            needed[by_topic[topic]] = count
        return needed

    def _try_start(self) -> None:
        if any(p.get_subscription_count() < n for p, n in self._needed.items()):
            return
        # free-timing readers announce no readiness: wait until the graph shows their subscriptions
        if any(self.count_subscribers(t) < n for t, n in self._graph_needed.items()):
            return
        if self.sub_cmd is not None and self.controlled and self.sub_cmd.get_publisher_count() < 1:
            return
        if any(step is None for step in self._next_needed.values()):
            return
        self._startup_timer.cancel()
        self.destroy_timer(self._startup_timer)
        self._started = True
        self.get_logger().info(
            f"starting: {self.config.profile}/{self.config.plant} at {self.config.sim_rate_hz:g} Hz "
            f"for {self.config.duration_s:g} s ({'controlled' if self.controlled else 'open loop'}, "
            f"{'realtime' if self.realtime else 'lockstep'})")
        self._publish_truth(self.core.truth())
        if self.realtime:
            # the stamps stay k·dt: only the wall-clock period between steps scales
            self.create_timer(self.config.dt / self.real_time_factor, self._realtime_step)
        elif not self.controlled:
            self._rearm = self.create_timer(0.0, self._open_loop_step)

    # --- commands --------------------------------------------------------------------------
    def _decoded(self, data: bytes):
        """The command's JointState, or None for a malformed one (counted and logged)."""
        try:
            return m.joint_state_from_cdr(data)
        except CdrError as exc:
            self.rejected_commands += 1
            self.get_logger().warning(f"malformed command ignored: {exc} ({self.rejected_commands} rejected)",
                                      throttle_duration_sec=1.0)
            return None

    def _on_command(self, data: bytes) -> None:
        msg = self._decoded(data)
        if msg is None:
            return
        k = m.step_of_stamp(msg.stamp_ns, self.config.sim_rate_hz)
        if self.realtime and self._started and k < self.core.k and (self._command_k is None or k > self._command_k):
            # late: the newest command is held for the next step (still counted late there)
            values = self._command_values(msg)
            if values is not None:
                self._command, self._command_k = values, k
            return
        if not self._started or k != self.core.k:
            self.rejected_commands += 1
            self.get_logger().warning(
                f"command stamped for step {k} while at step {self.core.k}: ignored "
                f"({self.rejected_commands} rejected)", throttle_duration_sec=1.0)
            return
        self._command_k = k
        values = self._command_values(msg)
        if values is not None:
            self._command = values
        if not self.realtime:
            self._advance()

    def _on_ros2_control(self, data: bytes) -> None:
        """A command in ros2_control's contract (module docstring): for the next step, whatever
        its stamp; a bad one is counted and that step holds the last good command."""
        msg = self._decoded(data)
        if msg is None:
            return
        if not self._started:
            self.rejected_commands += 1
            self.get_logger().warning(f"command before step 0: ignored ({self.rejected_commands} rejected)",
                                      throttle_duration_sec=1.0)
            return
        values = self._command_values(msg)
        if self.realtime:
            if values is not None:
                self._command = values
            self._command_k = self.core.k
            return
        self._queued.append(values)
        self._advance()

    def _on_progress(self, topic: str, data: bytes) -> None:
        step = m.step_of_stamp(m.clock_from_cdr(data), self.config.sim_rate_hz)
        self._next_needed[topic] = max(step, self._next_needed[topic] or 0)
        if self._started and not self.realtime:
            if self.controlled:
                self._advance()
            elif not self._open_loop_running:
                self._open_loop_step()

    def _command_values(self, msg: m.JointStateData) -> tuple[float, ...] | None:
        """The command in plant order, or None (counted, logged) if it must not be used."""
        effort = list(msg.effort)
        if msg.name:
            if set(msg.name) != set(self._command_names) or len(msg.name) != len(effort):
                problem = f"joint names {list(msg.name)} != {list(self._command_names)}"
            else:
                order = {name: i for i, name in enumerate(msg.name)}
                effort = [effort[order[name]] for name in self._command_names]
                problem = ""
        else:
            problem = "" if len(effort) == len(self._command_names) else f"{len(effort)} efforts"
        if not problem and not all(math.isfinite(v) for v in effort):
            problem = f"non-finite effort {effort}"
        if problem:
            self.rejected_commands += 1
            self.get_logger().warning(f"bad command ({problem}): holding the last good one "
                                      f"({self.rejected_commands} rejected)", throttle_duration_sec=1.0)
            return None
        return tuple(effort)

    # --- stepping --------------------------------------------------------------------------
    def _paced(self) -> bool:
        """True when publishing step k+1 would put it a window ahead of a pace reader."""
        return bool(self._next_needed) and min(self._next_needed.values()) + self.pace_window <= self.core.k + 1

    def _advance(self) -> bool:
        """Take step k -> k+1 if its command is in and no reader would be outrun."""
        if self.core.finished or self._paced():
            return False
        if self.controlled and not self.realtime:
            if self.ros2_control:
                if not self._queued:
                    return False
                values = self._queued.popleft()
                if values is not None:
                    self._command = values
            elif self._command_k != self.core.k:
                return False
        self.core.step(self._command)
        self._publish_truth(self.core.truth())
        if self.core.finished:
            self.get_logger().info(f"reached {self.core.t:g} s after {self.core.k} steps; "
                                   f"{self.rejected_commands} commands rejected, {self.late_commands} late")
            if self.exit_at_end:
                self.done.set_result(True)
        return True

    def _open_loop_step(self) -> None:
        # One step per callback of a zero-period timer ("again as soon as the executor is
        # idle", not a clock: what is computed never depends on when), so other callbacks
        # run between steps. When paced the timer stops and the next progress message
        # restarts it. (A guard condition would do, but the EventsExecutor has none.)
        self._open_loop_running = self._advance() and not self.core.finished
        if self._open_loop_running:
            if self._rearm.is_canceled():
                self._rearm.reset()
        elif not self._rearm.is_canceled():
            self._rearm.cancel()

    def _realtime_step(self) -> None:
        if self.sub_cmd is not None and self._command_k != self.core.k:
            self.late_commands += 1
        self._advance()

    def _publish_truth(self, truth: VehicleTruth) -> None:
        # serialized by nodes.wire (the engine writes the same bytes into its bag)
        t_ns = m.step_stamp_ns(truth.k, self.config.sim_rate_hz)
        site = self.core.profile.site if self.position_every and truth.k % self.position_every == 0 else None
        for topic, _, data in truth_messages(t_ns, truth, self.config.plant, site):
            self._pub_by_topic[topic].publish(data)


def main(argv: list[str] | None = None) -> int:
    return run_node(VehicleDynamicsNode, "vehicle_dynamics", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
