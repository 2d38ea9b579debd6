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
from typing import Callable

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


START_TIMEOUT_S = 120.0  # wall time a command may take to get to work on a loaded machine
EXIT_TIMEOUT_S = 60.0    # and to stop after the SIGINT


def interrupt_when(cmd: list[str], env: dict, out_dir: Path, ready: Callable[[], bool],
                   wait: Callable[[], None] = lambda: time.sleep(0.05),
                   sig: int = signal.SIGINT) -> tuple[int, str]:
    """Start ``cmd``; send it ``sig`` (SIGINT: Ctrl-C) once ``ready()`` (polled between
    ``wait()`` calls, never a wall-clock guess); its exit code and its stdout then stderr
    (kept in files in ``out_dir``: no pipe can fill up while we wait). The process is killed
    if it outlives this."""
    out, err = out_dir / "interrupted.stdout", out_dir / "interrupted.stderr"
    with open(out, "w") as fo, open(err, "w") as fe:
        proc = subprocess.Popen(cmd, env=env, stdout=fo, stderr=fe, text=True)
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not ready() and proc.poll() is None and time.monotonic() < deadline:
            wait()
        assert proc.poll() is None, f"{cmd[0]} ended before it was interrupted:\n{out.read_text()}{err.read_text()}"
        assert ready(), f"{cmd[0]} did not get to work within {START_TIMEOUT_S:g} s:\n{err.read_text()}"
        proc.send_signal(sig)
        proc.wait(timeout=EXIT_TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, out.read_text() + err.read_text()


def progress_sim_s(progress_file: Path) -> float:
    """The sim time in the orchestrator's progress file (GIMBAL_RUN_PROGRESS_FILE); 0 before."""
    try:
        return float(progress_file.read_text())
    except (OSError, ValueError):  # not written yet, or caught mid-write
        return 0.0


@contextmanager
def graph_names(domain_id: int):
    """A function giving the node names on the ROS graph of ``domain_id``, seen from an rclpy
    context of this test's own in that domain."""
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    try:
        probe = rclpy.create_node("graph_probe", context=ctx)
        yield probe.get_node_names
        probe.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)


def interrupt_when_on_graph(cmd: list[str], env: dict, name: str, out_dir: Path,
                            sig: int = signal.SIGINT) -> tuple[int, str]:
    """:func:`interrupt_when` its node ``name`` is on the graph."""
    with graph_names(int(env["ROS_DOMAIN_ID"])) as names:
        return interrupt_when(cmd, env, out_dir, lambda: name in names(), wait=lambda: time.sleep(0.1), sig=sig)
