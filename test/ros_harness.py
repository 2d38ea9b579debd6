"""Test helpers that start node executables and talk to them from the test process.

Each harness gets its own rclpy Context on the domain id of the ``ros_domain_env``
fixture, so its traffic never meets another test's. Every process started here is
stopped by its PID.
"""
from __future__ import annotations

import subprocess
import time
from contextlib import contextmanager
from pathlib import Path

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from conftest import VENV_BIN
from gimbal_sim.graph.orchestrator import stop_processes


def ros_args(params: dict) -> list[str]:
    """``--ros-args -p name:=value ...`` with values in ROS's YAML syntax."""
    out = ["--ros-args"]
    for name, value in params.items():
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            text = "[" + ",".join(f'"{v}"' if isinstance(v, str) else repr(float(v)) for v in value) + "]"
        elif isinstance(value, str):
            text = value
        else:
            text = repr(value)
        out += ["-p", f"{name}:={text}"]
    return out


@contextmanager
def node_processes(specs: list[tuple[str, dict]], env: dict, log_dir: Path):
    """Start ``[(executable, params), ...]``; yield the Popen objects; stop them by PID."""
    procs = []
    try:
        for exe, params in specs:
            log = open(log_dir / f"{exe}.log", "w")
            procs.append(subprocess.Popen([str(VENV_BIN / exe), *ros_args(params)], env=env,
                                          stdout=log, stderr=subprocess.STDOUT))
        yield procs
    finally:
        stop_processes(procs)


@contextmanager
def harness_node(domain_id: int, name: str = "test_harness"):
    """A node on its own Context and domain; yields (node, executor)."""
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = Node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


def spin_until(executor, predicate, timeout_s: float) -> bool:
    """Spin until ``predicate()`` is true; False if ``timeout_s`` of wall time passes first
    (a safety net against a hung graph, not a timing assertion)."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.05)
    return True


def start_refused(exe: str, params: dict, env: dict) -> subprocess.CompletedProcess:
    """Start node executable ``exe`` with ``params`` expecting it to refuse them; returns the
    finished process (a node that does start is killed after 60 s by the timeout)."""
    return subprocess.run([str(VENV_BIN / exe), *ros_args(params)], env=env, capture_output=True, text=True,
                          timeout=60)
