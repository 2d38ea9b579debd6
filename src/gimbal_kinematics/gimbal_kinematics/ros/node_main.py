"""``main()`` shared by every node executable (the ros2/demos pattern on Jazzy).

``--help`` is answered before rclpy starts. The node runs inside the commands' one error
boundary (:func:`gimbal_kinematics.cli.boundary.cli_boundary`): a parameter the node refuses,
a ``--params-file`` that is missing or not text, or one that has no block for the node or
names parameters it does not have (:func:`check_params_addressed`), ends the process with
exit code 2 and a message naming the parameter, the block or the file; Ctrl-C (SIGINT) ends
it with 130 and no traceback, SIGTERM (143) and SIGHUP (129) likewise; an unexpected
exception keeps its traceback, followed by the line saying it is a bug. Otherwise the node spins until an external shutdown (exit 0) or (if it has one) its
``done`` future completes (exit 0, or 1 with its ``failure`` line when it has one).
"""
from __future__ import annotations

import argparse
import difflib
import sys
import time
from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future
from rclpy.utilities import remove_ros_args
import yaml

from ..cli.boundary import Interrupted, RunFailed, UsageError, cli_boundary, on_stop_signals, read_text
from ..params.file import ParamsFileError, blocks, load_ros_yaml
from .ros_domain import localhost_env

#: How long one spin slice lasts [s]: a SIGINT is acted on within it.
SPIN_SLICE_S = 0.5
#: After a stop signal, a node that counts what it hears (``messages_heard``, e.g. the
#: recorder) spins on until it has heard nothing for SETTLE_QUIET_S [s], at most SETTLE_MAX_S:
#: what was sent to it before the stop is kept, not dropped with the process.
SETTLE_QUIET_S = 0.2
SETTLE_MAX_S = 5.0

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


def _params_files(argv: list[str]) -> list[str]:
    """The ``--params-file`` paths after ``--ros-args``."""
    in_ros_args, out = False, []
    for flag, value in zip(argv, argv[1:] + [""]):
        if flag == "--ros-args":
            in_ros_args = True
        elif flag == "--":
            in_ros_args = False
        elif in_ros_args and flag == "--params-file":
            out.append(value)
    return out


def _check_params_files(argv: list[str]) -> None:
    """Each ``--params-file`` after ``--ros-args`` is a readable text file (rcl itself takes a
    file that is not UTF-8 without a word, and the node would start without its parameters)."""
    for path in _params_files(argv):
        read_text(path, "--params-file")


def check_params_addressed(node: Node, argv: list[str]) -> None:
    """Each ``--params-file`` names this node and only parameters it has, or the node refuses
    to start (:class:`UsageError`, exit 2) naming the block or the parameters.

    ROS 2 itself starts the node on its defaults without a word when a block's node name is
    misspelt or a parameter name is; a run on defaults the user did not choose is a wrong
    result, so we refuse it, as ``gimbal-run`` refuses the same file. A wildcard block
    (``/**``) addresses every node, so a parameter it holds that this node lacks is left
    alone, as ROS 2 does; ``qos_overrides.*`` are rclpy's own."""
    fqn = node.get_fully_qualified_name()
    for path in _params_files(argv):
        where = f"--params-file {path}"
        try:
            found = blocks(load_ros_yaml(read_text(path, "--params-file")), where)
        except (ParamsFileError, yaml.YAMLError) as exc:
            raise UsageError(f"refused to start: {exc}") from None
        mine = [b for b in found if b.matches(fqn)]
        if not mine:
            raise UsageError(f"refused to start: {where} has no block for node {fqn} (its blocks: "
                             f"{', '.join(b.pattern for b in found)}): a misspelt node name? ROS 2 would run the node "
                             f"on its defaults without a word")
        for block in (b for b in mine if not b.wildcard):
            unknown = [n for n in block.params if not node.has_parameter(n) and not n.startswith("qos_overrides.")]
            if unknown:
                declared = list(node.get_parameters_by_prefix(""))
                hints = {n: difflib.get_close_matches(n, declared, 1) for n in unknown}
                names = ", ".join(f"{n!r}" + (f" (did you mean {h[0]!r}?)" if h else "") for n, h in hints.items())
                raise UsageError(f"refused to start: {where}: block {block.pattern} names parameters node {fqn} does "
                                 f"not have: {names}; ROS 2 would ignore them and run on the defaults")


def _settle(executor, node: Node) -> None:
    """Spin ``node`` until it has heard nothing for SETTLE_QUIET_S (nodes without a
    ``messages_heard`` count are left as they are)."""
    if not hasattr(node, "messages_heard"):
        return
    start = time.monotonic()
    heard, quiet_since = node.messages_heard, start
    while time.monotonic() - quiet_since < SETTLE_QUIET_S and time.monotonic() - start < SETTLE_MAX_S:
        executor.spin_once(timeout_sec=0.05)
        if node.messages_heard != heard:
            heard, quiet_since = node.messages_heard, time.monotonic()


def run_node(make_node: Callable[[], Node], prog: str, description: str, argv: list[str] | None = None) -> int:
    """Parse ``--help``, start rclpy, build the node and spin it; returns the exit code."""
    return cli_boundary(prog, "stopped the node")(_run_node)(make_node, prog, description, argv)


def _run_node(make_node: Callable[[], Node], prog: str, description: str, argv: list[str] | None) -> int:
    argv = list(sys.argv if argv is None else argv)
    parser = argparse.ArgumentParser(prog=prog, description=description, epilog=ROS_ARGS_EPILOG)
    try:
        non_ros_args = remove_ros_args(argv)
    except RuntimeError as exc:  # rcl's RCLInvalidROSArgsError
        raise UsageError(f"refused to start: malformed --ros-args: {exc}") from None
    parser.parse_args(non_ros_args[1:])
    _check_params_files(argv)
    localhost_env()
    rclpy.init(args=argv)
    # Ctrl-C / the orchestrator's SIGINT (and SIGTERM, SIGHUP: cli_boundary.STOP_SIGNALS) ends
    # the spin between slices, in place of rclpy's handler: that one shuts the context down
    # under a running callback, whose next publish fails, and a KeyboardInterrupt raised
    # inside a callback is no better (both are logged as [FATAL]). Installed before the node
    # is built, so a stop during its start-up (its parameter declarations publish) is clean
    # too. A Ctrl-C after the first stop signal aborts at once (a flooded EventsExecutor may
    # not return); a repeated SIGTERM or SIGHUP is not handed on (cli_boundary.on_stop_signals).
    stopping: list[int] = []

    def on_stop(signum: int) -> None:
        if stopping:
            raise KeyboardInterrupt
        stopping.append(signum)

    on_stop_signals(on_stop)
    try:
        node = make_node()
    except ValueError as exc:
        rclpy.try_shutdown()
        raise UsageError(f"refused to start: {exc}") from None
    except BaseException:
        rclpy.try_shutdown()
        raise
    if stopping:
        node.destroy_node()
        rclpy.try_shutdown()
        raise Interrupted("stopped the node while it started")
    try:
        check_params_addressed(node, argv)
    except UsageError:
        node.destroy_node()
        rclpy.try_shutdown()
        raise
    executor = make_executor()
    executor.add_node(node)
    try:
        done = getattr(node, "done", None) or Future()
        # In slices: rclpy 7.1.6's EventsExecutor never dispatches when spun without a
        # timeout (spin(), or spin_until_future_complete(f) with none), and holds the GIL.
        while not done.done() and not stopping:
            executor.spin_until_future_complete(done, timeout_sec=SPIN_SLICE_S)
        if stopping:
            _settle(executor, node)
    except ExternalShutdownException:
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    if stopping:
        raise Interrupted("stopped the node")
    if getattr(node, "failure", None):  # the node ended itself, failed (e.g. the recorder on a full disk)
        raise RunFailed(node.failure)
    return 0
