"""``main()`` shared by every node executable (the ros2/demos pattern on Jazzy).

``--help`` is answered before rclpy starts. A parameter the node refuses ends the process
with exit code 2 and a message naming the parameter. Otherwise the node spins until
Ctrl-C, an external shutdown, or (if it has one) its ``done`` future completes.
"""
from __future__ import annotations

import argparse
import signal
import sys
from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future
from rclpy.utilities import remove_ros_args

from .ros_domain import localhost_env

#: How long one spin slice lasts [s]: a SIGINT is acted on within it.
SPIN_SLICE_S = 1.0

ROS_ARGS_EPILOG = (
    "ROS arguments follow --ros-args, e.g. "
    "--ros-args --params-file config.yaml -p name:=value -r /old/topic:=/new/topic. "
    "Discovery stays on this host unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."
)


def make_executor(context=None):
    """The executor a node (or the container) spins on: ``GIMBAL_EXECUTOR=single`` for rclpy's
    SingleThreadedExecutor, ``events`` (default) for the C++ EventsExecutor."""
    import os

    if os.environ.get("GIMBAL_EXECUTOR", "events") == "single":
        return SingleThreadedExecutor(context=context)
    from rclpy.experimental import EventsExecutor

    return EventsExecutor(context=context)


def run_node(make_node: Callable[[], Node], prog: str, description: str, argv: list[str] | None = None) -> int:
    """Parse ``--help``, start rclpy, build the node and spin it; returns the exit code."""
    argv = list(sys.argv if argv is None else argv)
    parser = argparse.ArgumentParser(prog=prog, description=description, epilog=ROS_ARGS_EPILOG)
    try:
        non_ros_args = remove_ros_args(argv)
    except RuntimeError as exc:  # rcl's RCLInvalidROSArgsError
        print(f"{prog}: refused to start: malformed --ros-args: {exc}", file=sys.stderr)
        return 2
    parser.parse_args(non_ros_args[1:])
    localhost_env()
    rclpy.init(args=argv)
    # Ctrl-C / the orchestrator's SIGINT ends the spin between slices, in place of rclpy's
    # handler: that one shuts the context down under a running callback, whose next publish
    # fails, and a KeyboardInterrupt raised inside a callback is no better (both are logged
    # as [FATAL]). Installed before the node is built, so a Ctrl-C during its start-up (its
    # parameter declarations publish) stops it cleanly too. A second Ctrl-C aborts at once
    # (a flooded EventsExecutor may not return).
    stopping: list[int] = []

    def on_sigint(signum, _frame) -> None:
        if stopping:
            raise KeyboardInterrupt
        stopping.append(signum)

    signal.signal(signal.SIGINT, on_sigint)
    try:
        node = make_node()
    except ValueError as exc:
        print(f"{prog}: refused to start: {exc}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    except KeyboardInterrupt:
        rclpy.try_shutdown()
        return 0
    executor = make_executor()
    executor.add_node(node)
    try:
        done = getattr(node, "done", None) or Future()
        # In slices: rclpy 7.1.6's EventsExecutor never dispatches when spun without a
        # timeout (spin(), or spin_until_future_complete(f) with none), and holds the GIL.
        while not done.done() and not stopping:
            executor.spin_until_future_complete(done, timeout_sec=SPIN_SLICE_S)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
