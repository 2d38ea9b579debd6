"""``main()`` shared by every node executable (the ros2/demos pattern on Jazzy).

``--help`` is answered before rclpy starts. A parameter the node refuses ends the process
with exit code 2 and a message naming the parameter. Otherwise the node spins until
Ctrl-C, an external shutdown, or (if it has one) its ``done`` future completes.
"""
from __future__ import annotations

import argparse
import sys
from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from .ros_domain import localhost_env

ROS_ARGS_EPILOG = (
    "ROS arguments follow --ros-args, e.g. "
    "--ros-args --params-file config.yaml -p name:=value -r /old/topic:=/new/topic. "
    "Discovery stays on this host unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."
)


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
    try:
        node = make_node()
    except ValueError as exc:
        print(f"{prog}: refused to start: {exc}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        done = getattr(node, "done", None)
        if done is not None:
            executor.spin_until_future_complete(done)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
