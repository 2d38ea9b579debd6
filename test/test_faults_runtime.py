"""The fault matrix, runtime half: faults a run meets while it runs, each a data row.

* signals: SIGTERM, SIGHUP and SIGKILL of ``gimbal-run`` in both modes, SIGTERM of a node
  executable started alone;
* the disk: a full disk under a run (a 3 MiB tmpfs where the tests run as root, a fake
  ``write`` raising ENOSPC in the recorder elsewhere), ENOSPC and EIO in the bag writer, a
  run that cannot fit refused before it starts, a read-only output directory;
* the EKF and stamps: one outlier stamp (3 years ahead, zero), a sustained jump back or
  ahead, fed through the node's one timing edge; a publisher of the wrong type on an input;
* params: ``1e2`` in a params file, a misspelt parameter or node block given to a node
  started alone.

Every row asserts what the fault matrix asks of it: the exit code; no traceback; a message
that names the problem; the messages kept (counted by the ``mcap`` library, not by our
reader); no orphan process; no empty output folder.
"""
from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from conftest import VENV_BIN
from ros_harness import EXIT_TIMEOUT_S, interrupt_when, interrupt_when_on_graph, progress_sim_s

INTERRUPT_AT_S = 0.3       # simulated seconds reached before the signal
ORPHAN_TIMEOUT_S = 30.0    # a safety net for a loaded machine, not the figure (measured: docs/usage.md)


# ------------------------------------------------------------------ helpers
def _children(pid: int) -> list[int]:
    """PIDs whose parent is ``pid`` (from /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _running(pid: int) -> bool:
    """Alive and not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _gone_within(pids: list[int], timeout_s: float) -> float | None:
    """Seconds until every process in ``pids`` has ended; None when one outlives ``timeout_s``."""
    t0 = time.monotonic()
    while any(_running(p) for p in pids):
        if time.monotonic() - t0 > timeout_s:
            for p in pids:  # stop what the test started, by PID
                if _running(p):
                    os.kill(p, signal.SIGKILL)
            return None
        time.sleep(0.02)
    return time.monotonic() - t0


def _mcap_count(bag: Path) -> int:
    """Messages in a closed bag's MCAP files, counted by the ``mcap`` library."""
    total = 0
    for path in sorted(bag.glob("*.mcap")):
        with open(path, "rb") as f:
            total += sum(1 for _ in make_reader(f).iter_messages())
    return total


def _mcap_stream_count(path: Path) -> int:
    """Messages in the complete records of an MCAP that was never closed (``mcap``'s stream reader)."""
    from mcap.exceptions import McapError
    from mcap.records import Message

    n = 0
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, skip_magic=False, emit_chunks=False).records:
                n += isinstance(record, Message)
        except (McapError, EOFError, ValueError):  # the cut record at the end of a killed writer's file
            pass
    return n


def _metadata(bag: Path) -> dict:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


@pytest.fixture
def tmpfs(tmp_path):
    """Mount a tmpfs (``mount(size, read_only)``) under tmp_path; None where mounting is not permitted."""
    mounted: list[Path] = []

    def mount(size: str, read_only: bool = False) -> Path | None:
        where = tmp_path / f"fs{len(mounted)}"
        where.mkdir()
        opts = f"size={size}" + (",ro" if read_only else "")
        if shutil.which("mount") is None or subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(where)],
                                                           capture_output=True).returncode != 0:
            return None
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


# ------------------------------------------------------------------ signals
#: (signal, mode, exit code, the line that names it (None: SIGKILL says nothing), simulated
#: seconds before the signal: a SIGKILL in container mode after the first chunk boundary, 0.5 s)
SIGNAL_ROWS = [
    ("SIGTERM", "processes", 143, "gimbal-run: interrupted by SIGTERM: stopped the run at", INTERRUPT_AT_S),
    ("SIGTERM", "container", 143, "gimbal-run: interrupted by SIGTERM: stopped the run at", INTERRUPT_AT_S),
    ("SIGHUP", "processes", 129, "gimbal-run: interrupted by SIGHUP: stopped the run at", INTERRUPT_AT_S),
    ("SIGHUP", "container", 129, "gimbal-run: interrupted by SIGHUP: stopped the run at", INTERRUPT_AT_S),
    ("SIGKILL", "processes", -9, None, INTERRUPT_AT_S),
    ("SIGKILL", "container", -9, None, 1.5),
]


@pytest.mark.ros
@pytest.mark.parametrize("sig, mode, code, line, at_s", SIGNAL_ROWS, ids=[f"{r[0]}-{r[1]}" for r in SIGNAL_ROWS])
def test_a_signal_stops_gimbal_run_in_order(sig, mode, code, line, at_s, tmp_path, ros_domain_env):
    out, progress = tmp_path / "run", tmp_path / "progress"
    env = dict(ros_domain_env, GIMBAL_RUN_PROGRESS_FILE=str(progress))
    nodes: list[int] = []

    def ready() -> bool:
        if progress_sim_s(progress) < at_s:
            return False
        if not nodes:  # the orchestrator's node processes, before it is signalled
            nodes.extend(_children_of_cmd(out))
        return True

    cmd = [str(VENV_BIN / "gimbal-run"), "sim_open_loop", "--duration", "7200", "--mode", mode, "--out", str(out),
           "--no-progress"]
    rc, text = interrupt_when(cmd, env, tmp_path, ready, sig=getattr(signal, sig))
    gone = _gone_within(nodes, ORPHAN_TIMEOUT_S)
    logs = {p.name: p.read_text() for p in (out / "logs").glob("*.log")}
    assert rc == code, text
    for bad in ("Traceback", "[FATAL]"):
        assert bad not in text + "".join(logs.values()), text + "".join(logs.values())
    assert gone is not None, f"node processes {nodes} outlived the orchestrator by {ORPHAN_TIMEOUT_S} s"
    assert (mode == "processes") == bool(nodes) and len(nodes) == len(logs) * (mode == "processes")
    assert any(out.glob("*.mcap")), sorted(out.iterdir())  # never an empty output folder
    if sig == "SIGKILL" and mode == "container":
        # nothing could close the bag: every chunk on disk is kept and readable
        assert not (out / "metadata.yaml").exists()
        assert _mcap_stream_count(next(out.glob("*.mcap"))) > 0
        return
    if sig == "SIGKILL":
        # the nodes got the orchestrator's death as SIGTERM and stopped in order: the bag is closed
        for name, log in logs.items():
            assert f"{name.removesuffix('.log')}: interrupted by SIGTERM: stopped the node" in log, log
    else:
        assert line in text and "kept the bag (closed cleanly)" in text, text
        run = json.loads((out / "run.json").read_text())
        assert run["interrupted"] is True and at_s <= run["sim_s"] < 7200
        assert json.loads((out / "report" / "metrics.json").read_text())["message_count"] == _mcap_count(out)
    assert _metadata(out)["message_count"] == _mcap_count(out) > 0


def _children_of_cmd(out: Path) -> list[int]:
    """The node processes of the gimbal-run writing ``out`` (its children; none in container mode)."""
    owners = [int(p.parent.name) for p in Path("/proc").glob("[0-9]*/cmdline")
              if _cmdline_has(p, str(out)) and "gimbal-run" in _cmdline(p)]
    return [c for pid in owners for c in _children(pid)]


def _cmdline(p: Path) -> str:
    try:
        return p.read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _cmdline_has(p: Path, word: str) -> bool:
    return word in _cmdline(p).split()


@pytest.mark.ros
def test_sigterm_on_a_node_started_alone_exits_143(ros_domain_env, tmp_path):
    rc, text = interrupt_when_on_graph([str(VENV_BIN / "gyro_bias_ekf")], ros_domain_env, "gyro_bias_ekf", tmp_path,
                                       sig=signal.SIGTERM)
    assert rc == 143, text
    assert "Traceback" not in text and "[FATAL]" not in text, text
    assert "gyro_bias_ekf: interrupted by SIGTERM: stopped the node" in text, text


# ------------------------------------------------------------------ the disk
def _run_until_the_disk_is_full(out: Path, env: dict, fs: Path | None, monkeypatch) -> tuple[int, str]:
    """``gimbal-run`` of sighting_land_vehicle (EKF on, 8 s, container mode) into ``out``: as a
    process on the 3 MiB tmpfs ``fs``, or (no tmpfs) in this process with the recorder's
    ``write`` raising ENOSPC once 1.5 MB are written. Its exit code and output."""
    cmd = ["sighting_land_vehicle", "--variant", "ekf_on", "--duration", "8", "--mode", "container",
           "--out", str(out), "--no-progress", "--force"]
    if fs is not None:
        done = subprocess.run([str(VENV_BIN / "gimbal-run"), *cmd], env=env, capture_output=True, text=True,
                              timeout=300)
        return done.returncode, done.stdout + done.stderr
    from gimbal_sim.bag import writer
    from gimbal_sim.run_cli import main

    real = writer._DiskFile.write

    def write(self, data):
        if self.pos + len(data) > 1_500_000:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, data)

    monkeypatch.setattr(writer._DiskFile, "write", write)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    out_log, err_log = out.parent / "stdout", out.parent / "stderr"
    with open(out_log, "w") as fo, open(err_log, "w") as fe:
        monkeypatch.setattr(sys, "stdout", fo)
        monkeypatch.setattr(sys, "stderr", fe)
        rc = main(cmd)
    monkeypatch.undo()
    return rc, out_log.read_text() + err_log.read_text()


@pytest.mark.ros
def test_a_full_disk_stops_the_run_in_order_and_its_bag_replays(tmpfs, tmp_path, ros_domain_env, monkeypatch):
    fs = tmpfs("3m")
    out = (fs or tmp_path) / "run"
    rc, text = _run_until_the_disk_is_full(out, ros_domain_env, fs, monkeypatch)
    bag = out / "ekf_on"
    assert rc == 1, text
    assert "Traceback" not in text, text
    lines = [ln for ln in text.splitlines() if ln.startswith("gimbal-run: recording stopped: disk full")]
    assert len(lines) == 1, text  # one line, naming the device and its free space
    assert " free; stopped the run at " in lines[0] and "kept the bag (closed cleanly)" in lines[0], lines[0]
    if fs is not None:
        assert f"tmpfs on {fs}" in lines[0], lines[0]
    run = json.loads((bag / "run.json").read_text())
    assert run["stopped"] == "disk full" and 0 < run["sim_s"] < 8
    assert _metadata(bag)["custom_data"]["stopped"].startswith("disk full")
    kept = _mcap_count(bag)
    assert kept == _metadata(bag)["message_count"] > 0
    assert (bag / "report" / "index.html").is_file() and not (bag / ".space_reserve").exists()
    _replay_into_the_ekf(bag, ros_domain_env, tmp_path)


def _recorded(bag: Path, topic: str) -> dict[int, tuple[float, float, float]]:
    """{stamp [ns]: vector} of a Vector3Stamped topic, read and decoded by rosbags."""
    from rosbags.highlevel import AnyReader

    out = {}
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            out[msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = (msg.vector.x, msg.vector.y, msg.vector.z)
    return out


def _replay_into_the_ekf(bag: Path, env: dict, tmp_path: Path) -> None:
    """``gimbal-bag play`` of the bag's sensor topics into a fresh ``gyro_bias_ekf`` (the run's
    parameters, free timing, paced by its progress): its estimates are the run's, stamp for
    stamp, up to the bag's end (the harness of test_foreign_bag_ekf.py)."""
    import numpy as np
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    from ros_harness import harness_node, node_processes, spin_until

    want = _recorded(bag, "/gyro_bias_ekf/bias")
    assert len(want) > 50
    params = yaml.safe_load((bag / "params" / "gyro_bias_ekf.yaml").read_text())
    values = params["gyro_bias_ekf"]["ros__parameters"]
    values.update({"timing": "free", "qos_overrides./gyro_bias_ekf/bias.publisher.durability": "transient_local",
                   "qos_overrides./gyro_bias_ekf/bias.publisher.depth": 4 * len(want)})
    values = {k: v for k, v in values.items() if not isinstance(v, list) or v}  # an empty list has no type
    got: dict[int, np.ndarray] = {}
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
    with harness_node(int(env["ROS_DOMAIN_ID"])) as (node, executor):
        sub = node.create_subscription(Vector3Stamped, "/gyro_bias_ekf/bias", lambda msg: got.__setitem__(
            msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
            np.array([msg.vector.x, msg.vector.y, msg.vector.z])), keep_all)
        with node_processes([("gyro_bias_ekf", values)], env, tmp_path):
            assert spin_until(executor, lambda: sub.get_publisher_count() >= 1, 120.0)
            play = subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(bag), "--rate", "0",
                                     "--topics", "/gimbal/imu", "/gimbal/joint_states", "/ins/imu",
                                     "--pace", "/gyro_bias_ekf/progress", "--wait-for-subscribers", "1"],
                                    env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            try:
                delivered = spin_until(executor, lambda: set(want) <= set(got), 180.0)
                if not delivered:
                    play.kill()
                out, err = play.communicate(timeout=EXIT_TIMEOUT_S)
            finally:
                if play.poll() is None:
                    play.kill()
                    play.wait()
    assert delivered, f"{len(set(want) - set(got))} of {len(want)} estimates missing; play: {out}{err}"
    assert play.returncode == 0, out + err
    for t_ns, bias in want.items():
        assert np.max(np.abs(got[t_ns] - np.array(bias))) <= 1e-9, t_ns


#: (errno, where it strikes: a chunk's write or its fsync, the words of the line)
WRITER_ROWS = [(errno.ENOSPC, "write", "disk full (No space left on device)"),
               (errno.EIO, "sync", "disk I/O error (Input/output error)")]


@pytest.mark.parametrize("code, where, words", WRITER_ROWS, ids=["ENOSPC-write", "EIO-fsync"])
def test_a_disk_error_closes_the_bag_at_its_last_chunk_on_disk(code, where, words, tmp_path, monkeypatch):
    from gimbal_kinematics.ros import messages as m
    from gimbal_sim.bag import writer

    bag = writer.BagWriter(tmp_path / "bag", chunk_duration_ns=100_000_000, wall_flush_s=1e9)
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock", [])
    real_write, real_sync = writer._DiskFile.write, writer._DiskFile.sync
    flushes = []  # messages on disk at each chunk boundary (fsync'd)
    failed = []

    def fails() -> None:
        if len(flushes) >= 3 and not failed:  # the fourth chunk fails; the freed reserve's room is there
            failed.append(code)
            raise OSError(code, os.strerror(code))

    def write(self, data):
        if where == "write":
            fails()
        return real_write(self, data)

    def sync(self):
        if where == "sync":
            fails()
        real_sync(self)
        flushes.append(bag.message_count)

    monkeypatch.setattr(writer._DiskFile, "write", write)
    monkeypatch.setattr(writer._DiskFile, "sync", sync)
    written = 0
    with pytest.raises(writer.DiskStopped) as stop:
        for k in range(10_000):
            bag.write("/clock", m.clock_cdr(k * 1_000_000), k * 1_000_000)
            written += 1
    line = str(stop.value)
    assert line.startswith(words) and " has " in line and line.endswith(" free"), line
    assert bag.closed and bag.stopped == line
    kept = _mcap_count(tmp_path / "bag")
    # every chunk on disk before the failure is kept, nothing after it
    assert kept == flushes[-1] == _metadata(tmp_path / "bag")["message_count"] > 0
    assert kept < written + 1
    assert _metadata(tmp_path / "bag")["custom_data"] == {"stopped": line}
    assert not (tmp_path / "bag" / ".space_reserve").exists()


def test_a_run_its_disk_cannot_hold_is_refused_before_it_starts(tmp_path, capsys):
    from gimbal_sim.run_cli import main  # in this process: it is refused before anything starts

    out = tmp_path / "run"
    rc = main(["sim_open_loop", "--duration", "1e9", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "Traceback" not in err
    assert f"--out {out}: not enough room: the run needs about " in err and " free." in err and "--force" in err
    assert not out.exists()  # nothing started, nothing written


def test_a_read_only_output_directory_is_refused(tmpfs, tmp_path, capsys):
    from gimbal_sim.run_cli import main

    ro = tmpfs("1m", read_only=True)
    if ro is None:  # not root: a directory without write permission
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o555)
    out = ro / "run"
    rc = main(["sim_open_loop", "--duration", "1", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "Traceback" not in err
    assert str(out) in err and ("Read-only file system" in err or "not a writable" in err), err
    assert not out.exists()


# ------------------------------------------------------------------ the EKF and stamps
EPOCH_NS = 1_800_000_000_000_000_000
PERIOD_NS = 5_000_000                     # a 200 Hz gyro
THREE_YEARS_NS = 3 * 365 * 86_400 * 10**9


def _stream(n: int, start: int = EPOCH_NS) -> list[int]:
    return [start + k * PERIOD_NS for k in range(n)]


#: (case, the stamps of one gyro stream in arrival order, the counters it leaves:
#:  outliers, clock jumps, dropped, filter resets, samples fed to the core)
N = 150  # 0.75 s: longer than the node's clock_jump_s (0.5 s), so a bag loop is a jump back
STAMP_ROWS = [
    ("one stamp 3 years ahead", _stream(N) + [EPOCH_NS + THREE_YEARS_NS] + _stream(N, EPOCH_NS + N * PERIOD_NS),
     (1, 0, 0, 0, 2 * N)),
    ("one stamp of zero", _stream(N) + [0] + _stream(N, EPOCH_NS + N * PERIOD_NS), (1, 0, 0, 0, 2 * N)),
    ("two stamps of zero in a row", _stream(N) + [0, PERIOD_NS] + _stream(N, EPOCH_NS + N * PERIOD_NS),
     (2, 0, 0, 0, 2 * N)),
    ("a bag loop (sustained jump back)", _stream(N) + _stream(N), (0, 1, 0, 1, 2 * N)),
    ("a clock stepped 3 years ahead (sustained)", _stream(N) + _stream(N, EPOCH_NS + THREE_YEARS_NS),
     (0, 1, 0, 0, 2 * N)),
    ("two samples really missed", _stream(N) + _stream(N - 2, EPOCH_NS + (N + 2) * PERIOD_NS), (0, 0, 2, 0, 2 * N - 2)),
]


@pytest.mark.parametrize("case, stamps, counters", STAMP_ROWS, ids=[r[0] for r in STAMP_ROWS])
def test_the_ekf_timing_edge_rejects_outlier_stamps_and_resets_on_sustained_jumps(case, stamps, counters):
    """The ``gyro_bias_ekf`` node's free-timing input policy, as its constructor builds it
    (``order_policy``, its default ``clock_jump_s``), fed its gyro stream alone (the others
    would only hold the stamp order); ``on_restart`` is where the node resets its filter."""
    from gimbal_estimators.gyro_bias_ekf_params import PARAMS as EKF_PARAMS
    from gimbal_kinematics.params.table import defaults
    from gimbal_kinematics.timing.input_policy import order_policy

    resets, warnings = [], []
    policy = order_policy("free", ("gyro",), max_wait_ns=0, rate_hz=1000.0, progress_every=1,
                          clock_jump_ns=int(defaults(EKF_PARAMS)["clock_jump_s"] * 1e9), on_restart=resets.append)
    policy.held.warn = warnings.append
    fed = [step for s in stamps for step in policy.add("gyro", s, None)]
    c = policy.counters()
    assert (c["gyro_outliers"], c["gyro_clock_jumps"], c["gyro_dropped"], len(resets), len(fed)) == counters, c
    assert c["gyro_received"] == len(stamps)
    # the core sees every sample it is fed in stamp order (a new run after a reset)
    assert all(b.stamp_ns > a.stamp_ns for a, b in zip(fed, fed[1:]) if b.t > 0)
    if counters[0]:
        assert any("outliers" in w for w in warnings), warnings  # said, and counted


@pytest.mark.ros
def test_a_publisher_of_the_wrong_type_on_an_input_is_logged_once_and_on_diagnostics(ros_domain_env):
    from std_msgs.msg import String

    from gimbal_estimators.gyro_bias_ekf_node import GyroBiasEkfNode
    from ros_harness import harness_node, spin_until

    domain = int(ros_domain_env["ROS_DOMAIN_ID"])
    with harness_node(domain) as (harness, executor), harness_node(domain, "talker") as (talker, _):
        ekf = GyroBiasEkfNode(context=harness.context)
        executor.add_node(ekf)
        try:
            wrong = talker.create_publisher(String, "/gimbal/imu", 10)  # a plain rclpy publisher, its own context
            wrong.publish(String(data="not an Imu"))
            # the node's own periodic check (a steady timer) finds it
            assert spin_until(executor, lambda: ekf.edge.io.wrong_type == 1, 60.0), ekf.edge.io.counters()
            ekf.edge.io.check_types()
            ekf.edge.io.check_types()
            assert ekf.edge.io.wrong_type == 1  # one (topic, type): logged and counted once
            (status,) = ekf.health(0).status
            values = {kv.key: kv.value for kv in status.values}
            assert values["wrong_type"] == "1" and values["gyro_received"] == "0", values
        finally:
            executor.remove_node(ekf)
            ekf.destroy_node()


# ------------------------------------------------------------------ params
@pytest.mark.parametrize("spelling", ["1e2", "1.5e3", "2E-1", "+1e1", "1.0e+2", "100.0"])
def test_params_file_numbers_are_read_as_rclpy_reads_them(spelling, tmp_path):
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    from gimbal_sim.graph.scenario import apply_params_file, apply_set, load

    path = tmp_path / "p.yaml"
    path.write_text(f"gyro_bias_ekf:\n  ros__parameters:\n    max_gyro_gap_s: {spelling}\n")
    ctx = Context()
    rclpy.init(args=["--ros-args", "--params-file", str(path)], context=ctx)
    try:  # the oracle: what rclpy (rcl's YAML parser) gives a node started with the file
        node = Node("gyro_bias_ekf", context=ctx, automatically_declare_parameters_from_overrides=True)
        want = node.get_parameter("max_gyro_gap_s").value
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
    got = apply_params_file(load("sighting_land_vehicle"), path).nodes["gyro_bias_ekf"]["params"]["max_gyro_gap_s"]
    assert isinstance(want, float) and got == want, (spelling, want, got)
    # and --set, whose value is read as -p reads it
    got = apply_set(load("sighting_land_vehicle"), f"gyro_bias_ekf.max_gyro_gap_s={spelling}")
    assert got.nodes["gyro_bias_ekf"]["params"]["max_gyro_gap_s"] == want


#: (case, params file, the words of the one line)
PARAMS_ROWS = [
    ("misspelt parameter", "gyro_bias_ekf:\n  ros__parameters:\n    clock_jump_ss: 1.0\n",
     "block /gyro_bias_ekf names parameters node /gyro_bias_ekf does not have: 'clock_jump_ss' "
     "(did you mean 'clock_jump_s'?)"),
    ("misspelt node block", "gyro_bias_ekff:\n  ros__parameters:\n    clock_jump_s: 1.0\n",
     "has no block for node /gyro_bias_ekf (its blocks: /gyro_bias_ekff)"),
]


@pytest.mark.ros
@pytest.mark.parametrize("case, text, words", PARAMS_ROWS, ids=[r[0] for r in PARAMS_ROWS])
def test_a_node_started_alone_refuses_a_params_file_that_misses_it(case, text, words, tmp_path, ros_domain_env):
    path = tmp_path / "p.yaml"
    path.write_text(text)
    done = subprocess.run([str(VENV_BIN / "gyro_bias_ekf"), "--ros-args", "--params-file", str(path)],
                          env=ros_domain_env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith("gyro_bias_ekf: refused to start: ")]
    assert len(lines) == 1 and words in lines[0], done.stderr
