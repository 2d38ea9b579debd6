"""vehicle_dynamics' command contracts and pacing (:mod:`gimbal_sim.nodes.vehicle_commands`),
without ROS: messages are the CDR decoder's own records, built by hand."""
from __future__ import annotations

import math

from gimbal_kinematics.ros import messages as m
from gimbal_sim.nodes.vehicle_commands import CommandInbox, ReaderPace

RATE = 1000.0
NAMES = ("gimbal_pitch", "gimbal_yaw")


def cmd(k: int, effort, names=()) -> m.JointStateData:
    return m.JointStateData(m.step_stamp_ns(k, RATE), "", tuple(names), (), (), tuple(effort))


def inbox(realtime=False):
    warned = []
    return CommandInbox(NAMES, 2, RATE, realtime, warned.append), warned


def test_lockstep_takes_the_command_of_the_step_at_hand_only():
    box, warned = inbox()
    assert not box.on_command(cmd(0, (1.0, 2.0)), False, 0)  # before step 0
    assert box.on_command(cmd(0, (1.0, 2.0)), True, 0) and box.take(0, False) and box.command == (1.0, 2.0)
    assert not box.on_command(cmd(3, (5.0, 5.0)), True, 1)  # a future step
    assert not box.take(1, False) and box.rejected == 2 and len(warned) == 2
    # named joints in another order are put in plant order; a NaN holds the last good command
    assert box.on_command(cmd(1, (4.0, 3.0), NAMES[::-1]), True, 1) and box.command == (3.0, 4.0)
    assert box.on_command(cmd(2, (math.nan, 0.0)), True, 2) and box.command == (3.0, 4.0)
    assert box.on_command(cmd(3, (1.0,)), True, 3) and box.command == (3.0, 4.0) and box.rejected == 4


def test_realtime_holds_the_newest_late_command_and_counts_late_steps():
    box, _ = inbox(realtime=True)
    assert not box.on_command(cmd(2, (1.0, 1.0)), True, 5)  # late: held for the next step
    assert box.command == (1.0, 1.0) and box.command_k == 2 and box.rejected == 0
    assert not box.on_command(cmd(1, (9.0, 9.0)), True, 5)  # older than the held one: refused
    assert box.rejected == 1 and box.command == (1.0, 1.0)
    box.count_late(5)
    box.on_command(cmd(6, (2.0, 2.0)), True, 6)
    box.count_late(6)
    assert box.late == 1 and box.command == (2.0, 2.0)


def test_ros2_control_queues_one_command_per_lockstep_step():
    box, _ = inbox()
    assert not box.on_ros2_control(cmd(0, (1.0, 1.0)), False, 0) and box.rejected == 1
    assert box.on_ros2_control(cmd(77, (1.0, 1.0)), True, 0)  # whatever its stamp
    assert box.on_ros2_control(cmd(77, (math.inf, 1.0)), True, 0)
    assert box.take(0, True) and box.command == (1.0, 1.0)
    assert box.take(1, True) and box.command == (1.0, 1.0)  # the bad one holds the last good
    assert not box.take(2, True)


def test_a_reader_paces_the_vehicle_a_window_ahead():
    pace = ReaderPace(["/a/progress", "/b/progress"], window=10)
    assert not pace.ready
    pace.heard("/a/progress", 0)
    pace.heard("/b/progress", 5)
    assert pace.ready and not pace.holds(8) and pace.holds(9)
    pace.heard("/a/progress", 3)
    pace.heard("/a/progress", 2)  # an older progress never moves a reader back
    assert not pace.holds(11) and pace.holds(12)
    assert not ReaderPace([], 10).holds(10**6)
