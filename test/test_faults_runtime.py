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
#: (signal, mode, exit code, the line that names it; None: SIGKILL says nothing)
SIGNAL_ROWS = [
    ("SIGTERM", "processes", 143, "gimbal-run: interrupted by SIGTERM: stopped the run at"),
    ("SIGTERM", "container", 143, "gimbal-run: interrupted by SIGTERM: stopped the run at"),
    ("SIGHUP", "processes", 129, "gimbal-run: interrupted by SIGHUP: stopped the run at"),
    ("SIGKILL", "processes", -9, None),
    ("SIGKILL", "container", -9, None),
]


@pytest.mark.ros
@pytest.mark.parametrize("sig, mode, code, line", SIGNAL_ROWS, ids=[f"{r[0]}-{r[1]}" for r in SIGNAL_ROWS])
def test_a_signal_stops_gimbal_run_in_order(sig, mode, code, line, tmp_path, ros_domain_env):
    out, progress = tmp_path / "run", tmp_path / "progress"
    env = dict(ros_domain_env, GIMBAL_RUN_PROGRESS_FILE=str(progress))
    nodes: list[int] = []

    def ready() -> bool:
        if progress_sim_s(progress) < INTERRUPT_AT_S:
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
    assert "Traceback" not in text + "".join(logs.values()), text + "".join(logs.values())
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
        assert run["interrupted"] is True and INTERRUPT_AT_S <= run["sim_s"] < 7200
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
