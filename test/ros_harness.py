"""Test helpers that start node executables and talk to them from the test process.

Each harness gets its own rclpy Context on the domain id of the ``ros_domain_env``
fixture, so its traffic never meets another test's. Every process started here is
stopped by its PID.
"""
from __future__ import annotations

import signal
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


def wait_for_node_on_graph(name: str, domain_id: int, proc: subprocess.Popen, timeout_s: float = 120.0) -> None:
    """Wait until a node called ``name`` is on the ROS graph of ``domain_id`` (an rclpy
    context of this test's own in that domain), failing early if ``proc`` exits."""
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    try:
        probe = rclpy.create_node("workspace_probe", context=ctx)
        deadline = time.monotonic() + timeout_s
        while name not in probe.get_node_names():
            if proc.poll() is not None:
                out, err = proc.communicate()
                raise AssertionError(f"{name} exited with {proc.returncode}: {out}{err}")
            assert time.monotonic() < deadline, f"{name} did not appear on the graph in {timeout_s} s"
            time.sleep(0.1)
        probe.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)


def interrupt_when_on_graph(cmd: list[str], env: dict, name: str,
                            timeout_s: float = 120.0) -> tuple[subprocess.Popen, str, str]:
    """Start ``cmd``, send it SIGINT once its node ``name`` is on the graph, and return the
    ended process with its stdout and stderr (the process is killed if it outlives this)."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_node_on_graph(name, int(env["ROS_DOMAIN_ID"]), proc, timeout_s)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc, out, err
