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

import sys

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
from gimbal_kinematics.params.table import ros2_control_topic
from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.ros.params import declare_and_read
from ..world.vehicle import VehicleConfig, VehicleCore, VehicleTruth
from .vehicle_commands import COMMAND_JOINTS, CommandInbox, ReaderPace, StartGate
from .vehicle_dynamics_params import DESCRIPTION, PARAMS
from .wire import truth_messages


class VehicleDynamicsNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("vehicle_dynamics", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.config = VehicleConfig.from_values(values)
        self.core = VehicleCore(self.config, GIMBAL_MODELS[values["gimbal_model"]])
        self.controlled, self.realtime = values["controlled"], values["timing"] == "realtime"
        self.real_time_factor = float(values["real_time_factor"])
        self.exit_at_end = values["exit_at_end"]
        self.done = Future()
        plant = self.config.plant
        self.inbox = CommandInbox(COMMAND_JOINTS.get(plant, ()), self.config.command_size, self.config.sim_rate_hz,
                                  self.realtime, lambda text: self.get_logger().warning(text, throttle_duration_sec=1.0))
        self._started = self._open_loop_running = False
        truth = [(Clock, "/clock"), (Imu, "/truth/host/imu"), (Vector3Stamped, "/truth/host/delta_angle")]
        if plant != "host_only":
            prefix = "/truth/gimbal" if plant == "two_axis_gimbal" else "/truth/platform"
            truth += [(JointState, f"{prefix}/joint_states"), (Imu, f"{prefix}/imu")]
        # the host's true position and velocity, for a navigator's report (off by default: bags unchanged);
        # every motion profile holds the host at its site, so the velocity relative to the earth is zero
        self.position_every = values["position_truth_every_steps"]
        if self.position_every:
            truth += [(NavSatFix, "/truth/host/fix"), (Vector3Stamped, "/truth/host/velocity")]
        self._truth_pubs = [self.create_publisher(kind, topic, GRAPH_QOS) for kind, topic in truth]
        self.pace = ReaderPace(values["pace_topics"], values["pace_window_steps"])
        self._pace_subs = [self.create_subscription(Clock, topic, lambda data, t=topic: self._on_progress(t, data),
                                                    GRAPH_QOS, raw=True) for topic in self.pace.next_needed]
        self.sub_cmd = None
        self.ros2_control = values["command_interface"] == "ros2_control"
        command_topic = ros2_control_topic(values) if self.ros2_control else ""  # refused at start-up
        if plant != "host_only" and (self.controlled or self.realtime):
            if self.ros2_control:
                topic, qos, take = command_topic, ROS2_CONTROL_QOS, self.inbox.on_ros2_control
            else:
                topic = "/gimbal/torque_cmd" if plant == "two_axis_gimbal" else "/platform/voltage_cmd"
                # realtime: the command comes from a free-timing controller (node_io's outputs are volatile)
                qos, take = (input_qos("free") if self.realtime else GRAPH_QOS), self.inbox.on_command
            self.sub_cmd = self.create_subscription(JointState, topic, lambda data: self._on_command(take, data),
                                                    qos, raw=True)
        self._pub_by_topic = {p.topic_name: p for p in self._truth_pubs}
        self.start_gate = StartGate(self._pub_by_topic, values, self.count_subscribers,
                                    self.sub_cmd if self.controlled else None, self.pace)
        self._rearm = None  # open loop: zero-period timer that re-runs _open_loop_step (see there)
        self._startup_timer = self.create_timer(0.02, self._try_start)

    # --- start-up handshake -------------------------------------------------------------
    def _try_start(self) -> None:
        if not self.start_gate.open():
            return
        self._startup_timer.cancel()
        self.destroy_timer(self._startup_timer)
        self._started = True
        c, loop = self.config, "controlled" if self.controlled else "open loop"
        self.get_logger().info(f"starting: {c.profile}/{c.plant} at {c.sim_rate_hz:g} Hz for {c.duration_s:g} s "
                               f"({loop}, {'realtime' if self.realtime else 'lockstep'})")
        self._publish_truth(self.core.truth())
        if self.realtime:
            # the stamps stay k·dt: only the wall-clock period between steps scales
            self.create_timer(self.config.dt / self.real_time_factor, self._realtime_step)
        elif not self.controlled:
            self._rearm = self.create_timer(0.0, self._open_loop_step)

    # --- commands and progress ------------------------------------------------------------
    def _on_command(self, take, data: bytes) -> None:
        """A command to the inbox's contract (:mod:`.vehicle_commands`); a step if it completes one."""
        try:
            msg = m.joint_state_from_cdr(data)
        except CdrError as exc:
            return self.inbox.refuse(f"malformed command ignored: {exc}")
        if take(msg, self._started, self.core.k):
            self._advance()

    def _on_progress(self, topic: str, data: bytes) -> None:
        self.pace.heard(topic, m.step_of_stamp(m.clock_from_cdr(data), self.config.sim_rate_hz))
        if self._started and not self.realtime:
            if self.controlled:
                self._advance()
            elif not self._open_loop_running:
                self._open_loop_step()

    # --- stepping --------------------------------------------------------------------------
    def _advance(self) -> bool:
        """Take step k -> k+1 if its command is in and no reader would be outrun."""
        if self.core.finished or self.pace.holds(self.core.k):
            return False
        if self.controlled and not self.realtime and not self.inbox.take(self.core.k, self.ros2_control):
            return False
        self.core.step(self.inbox.command)
        self._publish_truth(self.core.truth())
        if self.core.finished:
            self.get_logger().info(f"reached {self.core.t:g} s after {self.core.k} steps; "
                                   f"{self.inbox.rejected} commands rejected, {self.inbox.late} late")
            if self.exit_at_end:
                self.done.set_result(True)
        return True

    def _open_loop_step(self) -> None:
        # One step per callback of a zero-period timer ("again when idle", not a clock), so other callbacks run
        # between steps; paced, it stops until the next progress (the EventsExecutor has no guard condition).
        self._open_loop_running = self._advance() and not self.core.finished
        if self._open_loop_running:
            if self._rearm.is_canceled():
                self._rearm.reset()
        elif not self._rearm.is_canceled():
            self._rearm.cancel()

    def _realtime_step(self) -> None:
        if self.sub_cmd is not None:
            self.inbox.count_late(self.core.k)
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
