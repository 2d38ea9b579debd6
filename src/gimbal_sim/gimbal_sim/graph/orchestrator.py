"""Run a scenario: start its nodes and the recorder, wire readiness and pacing, watch the
run to its end, stop everything cleanly and leave a complete bag plus its report.

Modes: ``processes`` runs each node as its own OS process through the same executables
``ros2 run`` uses; ``container`` runs all nodes in this process on one executor. Both get
the same ``--ros-args`` (node name, generated params file, remaps), so a run is the same
run in either mode.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import yaml

from gimbal_kinematics.cli.boundary import on_stop_signals
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.ros_domain import claim_domain_id, die_with_parent, localhost_env

from .plan import ProcessStats, RECORDER, plan_nodes, process_stats, resident_mb, write_run_files
from .registry import NODE_TYPES
from .scenario import Scenario

STOP_GRACE_S = 10.0      # how long a node may take to exit after SIGINT
DRAIN_QUIET_S = 0.3      # quiet time after the run's end (or Ctrl-C) for its last /clock steps


class RunError(RuntimeError):
    """The run failed; the message names the node and why."""


@dataclass
class RunResult:
    out_dir: Path
    wall_s: float
    sim_s: float
    logs: dict[str, Path] = field(default_factory=dict)
    #: node name (or "container") -> its process's CPU time and peak RSS over the run
    processes: dict[str, ProcessStats] = field(default_factory=dict)
    #: the orchestrator's own process (its monitor node; in container mode, every node)
    orchestrator: ProcessStats | None = None
    #: wall arrival time [s] and stamp [ns] of each /clock message the monitor received
    clock_wall: array = field(default_factory=lambda: array("d"))
    clock_stamp: array = field(default_factory=lambda: array("q"))
    #: process name -> [(sim time [s], resident memory [MiB])], about once a wall second
    rss_samples: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    #: process name -> CPU seconds it had used when the first step was seen (start-up cost)
    cpu_at_start: dict[str, float] = field(default_factory=dict)
    #: Ctrl-C (SIGINT, SIGTERM, SIGHUP) stopped the run before its end; ``sim_s`` is the time it reached
    interrupted: bool = False
    #: why the recorder stopped the run before its end (a full disk: the device, its free space), else None
    stopped: str | None = None

    @property
    def real_time_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else float("inf")


def _tail(path: Path, lines: int = 15) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return "(no log)"


class Monitor:
    """The orchestrator's own node: follows /clock and the recorder's progress."""

    def __init__(self, context, scenario: Scenario) -> None:
        from rclpy.node import Node
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.task import Future
        from rosgraph_msgs.msg import Clock

        self.node = Node("gimbal_run_monitor", context=context)
        self.sim_ns = 0
        self.recorded_ns = 0
        self.end_ns = int(round(scenario.duration_s * 1e9))
        #: completes when the recorder has the last step
        self.done = Future()
        #: wall arrival time [s, monotonic] of each /clock message and its stamp [ns]
        self.clock_wall = array("d")
        self.clock_stamp = array("q")
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        now = time.monotonic

        def on_clock(data):
            t_ns = m.clock_from_cdr(data)
            if not self.clock_wall:  # first step: what each process used to start up
                self.cpu_at_start = {name: process_stats(pid).cpu_s for name, pid in self.pids.items()}
                self.cpu_at_start["orchestrator"] = process_stats().cpu_s
            self.clock_wall.append(now())
            self.clock_stamp.append(t_ns)
            if t_ns > self.sim_ns:
                self.sim_ns = t_ns

        def on_recorded(data):
            self.recorded_ns = max(self.recorded_ns, m.clock_from_cdr(data))
            if self.recorded_ns >= self.end_ns and not self.done.done():
                self.done.set_result(True)

        self.rss_samples: dict[str, list[tuple[float, float]]] = {}
        self.cpu_at_start: dict[str, float] = {}
        #: process name -> pid ("self" for this process), set by the runner
        self.pids: dict[str, int | str] = {}
        self.node.create_subscription(Clock, "/clock", on_clock, qos, raw=True)
        # transient-local like the recorder's publisher: a short run may end before this
        # node has discovered the recorder, and its last progress must still arrive
        self.node.create_subscription(Clock, f"/{RECORDER}/progress", on_recorded, GRAPH_QOS, raw=True)

    @property
    def finished(self) -> bool:
        """The recorder has the run's last step (its progress passed the end time)."""
        return self.recorded_ns >= self.end_ns


#: A file the run keeps its sim time [s] in, for a parent (``gimbal-run --jobs``) drawing the bar.
PROGRESS_FILE_ENV = "GIMBAL_RUN_PROGRESS_FILE"


class Progress:
    """Sim time against duration and the real-time factor, on stderr (and, when
    ``$GIMBAL_RUN_PROGRESS_FILE`` is set, the sim time in that file)."""

    def __init__(self, duration_s: float, enabled: bool = True) -> None:
        from tqdm import tqdm

        path = os.environ.get(PROGRESS_FILE_ENV)
        self.file = Path(path) if path else None

        # disable=None: tqdm stays quiet when stderr is not a terminal (CI logs, pipes)
        self.bar = tqdm(total=round(duration_s, 3), unit="sim s", disable=None if enabled else True,
                        file=sys.stderr,
                        bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}{postfix}]")
        self.t0 = time.monotonic()
        self._last_draw = 0.0

    def update(self, sim_s: float) -> None:
        now = time.monotonic()
        if now - self._last_draw < 0.25 and sim_s < self.bar.total:
            return
        self._last_draw = now
        if self.file is not None:
            self.file.write_text(f"{sim_s:.3f}\n")
        self.bar.n = round(min(sim_s, self.bar.total), 3)
        wall = now - self.t0
        self.bar.set_postfix_str(f"RTF {sim_s / wall:.2f}" if wall > 0 else "", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()


def _ros_env() -> tuple[dict[str, str], Any]:
    """Environment for the run's processes: loopback discovery and a domain of its own unless
    the user chose one. The discovery range is set in ``os.environ`` too (container mode
    starts rclpy in this process); the domain id is not, so a claim released at the end of
    this run is not inherited by the next run of the same process."""
    env = dict(localhost_env())
    claim = None
    if not env.get("ROS_DOMAIN_ID"):
        claim = claim_domain_id()
        env["ROS_DOMAIN_ID"] = str(claim.domain_id)
    return env, claim


def run(scenario: Scenario, out_dir: Path, mode: str = "processes", progress: bool = True,
        stall_timeout_s: float = 60.0, compress: bool = True, live: dict | None = None) -> RunResult:
    """Run ``scenario`` into ``out_dir`` (which must not exist); raises :class:`RunError`.
    ``compress``: the recorder zstd-compresses the bag's MCAP chunks; ``live``: the
    recorder's live-view parameters (live_port, ...), none for no live view."""
    out_dir = Path(out_dir)
    if out_dir.exists():
        raise FileExistsError(f"output directory {out_dir} already exists; not overwriting it")
    nodes = plan_nodes(scenario, out_dir, compress, live)
    write_run_files(scenario, nodes, out_dir)
    env, claim = _ros_env()
    stop = _StopRequest()
    try:
        runner = _run_processes if mode == "processes" else _run_container
        return runner(scenario, nodes, out_dir, env, progress, stall_timeout_s, stop)
    finally:
        stop.restore()
        if claim is not None:
            # the id is free again: a later run in this process must claim its own
            os.environ.pop("ROS_DOMAIN_ID", None)
            claim.release()


def _watch(scenario: Scenario, monitor: Monitor, spin, bar: Progress, stall_timeout_s: float,
           check_nodes, pids: dict[str, int | str], stop: _StopRequest) -> tuple[float, bool]:
    """Spin until the recorder has the last step, Ctrl-C (or SIGTERM, SIGHUP) or the recorder
    stopped (a full disk: ``stop.reason``); returns the wall time [s] and whether a signal
    stopped it (the graph is then stopped like at the end, the bag closed).

    ``spin(timeout)`` handles callbacks until the run is done or ``timeout`` [s] passed;
    between slices the nodes are checked, the progress bar drawn and, about once a second,
    the resident memory of each process in ``pids`` sampled.
    """
    t0 = time.monotonic()
    monitor.pids = pids
    _watch_loop(monitor, spin, bar, stall_timeout_s, check_nodes, pids, stop)
    return time.monotonic() - t0, stop.requested


class _StopRequest:
    """Ctrl-C (SIGINT), SIGTERM or SIGHUP during the run asks the watch to stop, as its end
    would: a flag read between spin slices, never an exception raised inside a node's
    callback (rclpy logs that as [FATAL]). A second signal must not abort the orderly stop
    that closes the bag. Only the main thread receives signals; elsewhere nothing is
    installed (``run`` puts the previous handlers back with :meth:`restore`)."""

    def __init__(self) -> None:
        self.requested = False
        #: why the recorder stopped the run (a full disk), set by the watch
        self.reason: str | None = None
        self.restore = on_stop_signals(self._on_signal)

    def _on_signal(self, _signum: int) -> None:
        if self.requested:
            print("gimbal-run: still stopping the nodes and closing the bag; please wait", file=sys.stderr)
        self.requested = True


def _watch_loop(monitor: Monitor, spin, bar: Progress, stall_timeout_s: float, check_nodes,
                pids: dict[str, int | str], stop: _StopRequest) -> None:
    last_change, last_state = time.monotonic(), None
    next_rss = last_change
    while not monitor.finished and not stop.requested and stop.reason is None:
        spin(0.1)
        stop.reason = check_nodes()
        bar.update(monitor.sim_ns / 1e9)
        state, now = (monitor.sim_ns, monitor.recorded_ns), time.monotonic()
        if now >= next_rss:
            next_rss = now + 1.0
            for name, pid in pids.items():
                monitor.rss_samples.setdefault(name, []).append((monitor.sim_ns / 1e9, resident_mb(pid)))
        if state != last_state:
            last_change, last_state = now, state
        elif now - last_change > stall_timeout_s:
            raise RunError(f"no progress for {stall_timeout_s:g} s (sim time {monitor.sim_ns / 1e9:g} s, "
                           f"recorded {monitor.recorded_ns / 1e9:g} s): a node is stuck or never became ready")


def _spin_slice(executor, monitor: Monitor, timeout: float) -> None:
    """Handle callbacks for about ``timeout`` [s] or until the run is done. One callback per
    spin_once: the EventsExecutor ignores the timeout of spin_until_future_complete while
    callbacks keep coming, and the run must stay watched."""
    end = time.monotonic() + timeout
    while not monitor.done.done():
        left = end - time.monotonic()
        if left <= 0.0:
            return
        executor.spin_once(timeout_sec=left)


def _result(out_dir: Path, wall: float, monitor: Monitor, **kw) -> RunResult:
    return RunResult(out_dir, wall, monitor.sim_ns / 1e9, orchestrator=process_stats(),
                     clock_wall=monitor.clock_wall, clock_stamp=monitor.clock_stamp,
                     rss_samples=monitor.rss_samples, cpu_at_start=monitor.cpu_at_start, **kw)


def _run_processes(scenario, nodes, out_dir, env, progress, stall_timeout_s, stop) -> RunResult:
    import rclpy
    from rclpy.context import Context

    from gimbal_kinematics.ros.node_main import make_executor

    bin_dir = Path(sys.executable).parent
    procs: dict[str, subprocess.Popen] = {}
    logs = {n.name: out_dir / "logs" / f"{n.name}.log" for n in nodes}
    context = Context()
    rclpy.init(context=context, domain_id=int(env["ROS_DOMAIN_ID"]))
    monitor = Monitor(context, scenario)
    executor = make_executor(context)
    executor.add_node(monitor.node)
    bar = Progress(scenario.duration_s, progress)

    def check_nodes(names: Iterable[str] | None = None) -> str | None:
        """None while every node (of ``names``) runs; why the recorder stopped the run; else RunError."""
        for name, proc in procs.items():
            if names is not None and name not in names:
                continue
            code = proc.poll()
            if code is not None and name == RECORDER and _recorder_stopped(out_dir):
                return _recorder_stopped(out_dir)
            if code is not None:
                raise RunError(f"node {name!r} exited with code {code} during the run; its last log lines:\n"
                               f"{_tail(logs[name])}")
        return None

    try:
        for node in nodes:
            exe = bin_dir / node.executable
            if not exe.exists():
                raise RunError(f"executable {node.executable} not found in {bin_dir}; run `make venv`")
            with open(logs[node.name], "w") as log:
                # a process group of its own: a terminal's Ctrl-C reaches the orchestrator only,
                # which stops the nodes in order (the recorder last); and SIGTERM when the
                # orchestrator dies, however it dies (SIGKILL included): no node outlives it
                procs[node.name] = subprocess.Popen([str(exe), *node.ros_args()], env=env, stdout=log,
                                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                                    process_group=0, preexec_fn=die_with_parent())
        wall, interrupted = _watch(scenario, monitor, lambda timeout: _spin_slice(executor, monitor, timeout),
                      bar, stall_timeout_s, check_nodes, {name: proc.pid for name, proc in procs.items()},
                                   stop)
        quiet_until = time.monotonic() + DRAIN_QUIET_S
        while time.monotonic() < quiet_until and stop.reason is None:
            executor.spin_once(timeout_sec=0.05)
            stop.reason = check_nodes()
        # a recorder the disk stopped has exited: nothing left to read of it
        stats = {name: process_stats(proc.pid) for name, proc in procs.items() if proc.poll() is None}
        # the nodes stop before the time reached is read, the recorder still running: after a
        # Ctrl-C nothing is simulated past that time, and the recorder takes what was sent
        stop_processes(proc for name, proc in procs.items() if name != RECORDER)
        quiet_until = time.monotonic() + (DRAIN_QUIET_S if interrupted else 0.0)
        while time.monotonic() < quiet_until and stop.reason is None:
            executor.spin_once(timeout_sec=0.05)
            stop.reason = check_nodes([RECORDER])
        return _result(out_dir, wall, monitor, logs=logs, processes=stats, interrupted=interrupted,
                       stopped=stop.reason)
    finally:
        bar.close()
        _stop(procs, first=[n.name for n in nodes if n.name != RECORDER], last=[RECORDER])
        executor.shutdown()
        monitor.node.destroy_node()
        rclpy.shutdown(context=context)


def _recorder_stopped(out_dir: Path) -> str | None:
    """Why the recorder stopped the recording before its end, from the bag's metadata (its
    ``custom_data.stopped``: a full disk, the device and its free space), else None."""
    try:
        info = yaml.safe_load((out_dir / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        stopped = (info.get("custom_data") or {}).get("stopped")
    except (OSError, yaml.YAMLError, KeyError, TypeError, AttributeError):
        return None
    return f"recording stopped: {stopped}" if stopped else None


def stop_processes(procs: Iterable[subprocess.Popen], grace_s: float = STOP_GRACE_S) -> None:
    """SIGINT each process still running, by PID; SIGKILL any that outlives ``grace_s`` [s]."""
    procs = [p for p in procs if p is not None]
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + grace_s
    for proc in procs:
        try:
            proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _stop(procs: dict[str, subprocess.Popen], first: list[str], last: list[str]) -> None:
    """Stop the run's processes, the recorder last, so it closes the bag after the rest are gone."""
    for group in (first, last):
        stop_processes(procs.get(name) for name in group)


def _run_container(scenario, nodes, out_dir, env, progress, stall_timeout_s, stop) -> RunResult:
    import rclpy
    from rclpy.context import Context

    from gimbal_kinematics.ros.node_main import make_executor

    context = Context()
    rclpy.init(context=context, domain_id=int(env["ROS_DOMAIN_ID"]))
    executor = make_executor(context)
    monitor = Monitor(context, scenario)
    executor.add_node(monitor.node)
    bar = Progress(scenario.duration_s, progress)
    built = {}
    try:
        # Import every node module before the first node starts, so that the nodes come up
        # back to back: the order their ready messages reach the recorder depends on it.
        classes = {node.name: NODE_TYPES[node.executable].node_class() for node in nodes}
        for node in nodes:
            cls = classes[node.name]
            try:
                built[node.name] = cls(context=context, cli_args=node.ros_args(), use_global_arguments=False)
            except ValueError as exc:
                raise RunError(f"node {node.name!r} refused to start: {exc}") from exc
            executor.add_node(built[node.name])

        def spin(timeout: float, until_done: bool = True) -> None:
            try:
                if until_done:
                    _spin_slice(executor, monitor, timeout)
                else:
                    executor.spin_once(timeout_sec=timeout)
            except Exception as exc:  # noqa: BLE001 - any node's failure ends the run, named
                raise RunError(f"a node failed in container mode: {type(exc).__name__}: {exc}") from exc

        def check_nodes() -> str | None:
            """Why the recorder stopped the run (as the bag's metadata says, or its own line), else None."""
            failure = getattr(built.get(RECORDER), "failure", None)
            return failure and (_recorder_stopped(out_dir) or failure)

        wall, interrupted = _watch(scenario, monitor, spin, bar, stall_timeout_s, check_nodes, {"container": "self"},
                                   stop)
        quiet_until = time.monotonic() + DRAIN_QUIET_S
        while time.monotonic() < quiet_until and stop.reason is None:
            spin(0.05, until_done=False)
            stop.reason = check_nodes()
        return _result(out_dir, wall, monitor, processes={"container": process_stats()}, interrupted=interrupted,
                       stopped=stop.reason)
    finally:
        bar.close()
        recorder = built.pop(RECORDER, None)
        for node in built.values():
            executor.remove_node(node)
            node.destroy_node()
        if recorder is not None:
            recorder.close()
            recorder.destroy_node()
        executor.shutdown()
        monitor.node.destroy_node()
        rclpy.shutdown(context=context)
