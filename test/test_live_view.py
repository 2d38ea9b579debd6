"""``gimbal-run --live``: an independent client (``@foxglove/ws-protocol`` 0.8.0, the client
Lichtblick uses, in Node) connects with each subprotocol name, decodes the relayed CDR with
``@foxglove/rosmsg2-serialization`` and gets the values the run's bag holds for the same stamps.
"""
from __future__ import annotations

import json
import re
import select
import shutil
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from conftest import VENV_BIN
from gimbal_sim.bag.live import SDK_SUBPROTOCOL, LEGACY_SUBPROTOCOL, _offered_legacy, parse_topic_rates
from gimbal_sim.bag.reader import BagContents, read_messages, stream
from gimbal_sim.reports.common import vehicle_site

CLIENT_DIR = Path(__file__).parent / "live_client"
TOPICS = ("/gimbal/imu", "/gyro_bias_ekf/bias")
FRAMES = "/live/frames"
LOS = "/live/los"
DRIFT = "/live/los_drift"
BOUNDS = "/live/bias_bounds"
LAYOUT = Path(__file__).resolve().parents[1] / "docs" / "foxglove" / "gimbal_live.json"
CHAIN = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.fixture(scope="session")
def node_client(tmp_path_factory) -> Path:
    """The client script with its pinned npm packages installed beside it."""
    if not shutil.which("node") or not shutil.which("npm"):
        pytest.skip("node and npm are needed for the independent Foxglove client (apt install nodejs npm)")
    work = tmp_path_factory.mktemp("live_client")
    for name in ("package.json", "client.cjs"):
        shutil.copy(CLIENT_DIR / name, work / name)
    done = subprocess.run(["npm", "install", "--no-audit", "--no-fund", "--no-package-lock"], cwd=work,
                          capture_output=True, text=True, timeout=300)
    if done.returncode != 0:
        pytest.skip(f"npm could not install the pinned client packages: {done.stderr[-500:]}")
    return work / "client.cjs"


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _wait_listening(port: int, proc: subprocess.Popen, timeout_s: float = 90.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
            return
        except OSError:
            time.sleep(0.2)
    raise AssertionError(f"no live view on port {port} (run exit {proc.poll()})")


def _client(script: Path, port: int, subprotocol: bytes, count: int, topics=TOPICS) -> list[dict]:
    done = subprocess.run(["node", str(script), f"ws://127.0.0.1:{port}", subprotocol.decode(), str(count),
                           *topics], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = [json.loads(line) for line in done.stdout.splitlines()]
    assert lines[0] == {"open": subprotocol.decode()}  # the name the client offered, accepted
    return lines[1:]


def _client_killed_mid_stream(script: Path, port: int) -> None:
    """A client that subscribes, gets messages and is killed (SIGKILL: no WebSocket close, the
    kernel resets its connection while the server is still sending)."""
    proc = subprocess.Popen(["node", str(script), f"ws://127.0.0.1:{port}", SDK_SUBPROTOCOL.decode(), "1000000",
                             *TOPICS], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    try:
        deadline = time.monotonic() + 60.0
        while len(lines) < 3 and time.monotonic() < deadline and proc.poll() is None:
            if select.select([proc.stdout], [], [], 1.0)[0]:
                lines.append(proc.stdout.readline())
    finally:
        proc.kill()
        proc.wait()
    assert len(lines) == 3 and json.loads(lines[0]) == {"open": SDK_SUBPROTOCOL.decode()}, lines
    assert json.loads(lines[2])["topic"] in TOPICS  # killed while messages were flowing


def _stamp_ns(msg: dict) -> int:
    return int(msg["header"]["stamp"]["sec"]) * 1_000_000_000 + int(msg["header"]["stamp"]["nanosec"])


def test_both_subprotocols_get_the_bags_values(node_client, tmp_path, ros_domain_env):
    port = _free_port()
    cmd = [str(VENV_BIN / "gimbal-run"), "sighting_land_vehicle", "--variant", "ekf_on", "--duration", "6",
           "--no-progress", "--live", "--live-port", str(port)]
    run = subprocess.Popen([*cmd, "--out", str(tmp_path / "run")], env=ros_domain_env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    second = None
    try:
        _wait_listening(port, run)
        # a second run asking for the port this live view holds: refused before it starts anything
        second = subprocess.Popen([str(VENV_BIN / "gimbal-run"), "gyro_at_rest", "--duration", "1", "--live",
                                   "--live-port", str(port), "--out", str(tmp_path / "second")],
                                  env=ros_domain_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # a client killed mid-stream (no close handshake), one disconnecting cleanly, then another
        # connecting: the last two served, the run goes on
        _client_killed_mid_stream(node_client, port)
        received = _client(node_client, port, LEGACY_SUBPROTOCOL, 5, (*TOPICS, FRAMES, LOS))
        received += _client(node_client, port, SDK_SUBPROTOCOL, 5, (*TOPICS, FRAMES, LOS, DRIFT, BOUNDS))
        second_out, second_err = second.communicate(timeout=120)
        output, _ = run.communicate(timeout=240)
    finally:
        for proc in (run, second):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
    assert run.returncode == 0, output
    assert second.returncode == 2, second_out + second_err
    assert f"port {port}" in second_err and "Traceback" not in second_err + second_out, second_err
    assert not (tmp_path / "second").exists()
    frames = [m for m in received if m["topic"] == FRAMES]
    los = [m for m in received if m["topic"] == LOS]
    derived = [m for m in received if m["topic"] in (DRIFT, BOUNDS)]
    received = [m for m in received if m["topic"] in TOPICS]
    assert len(received) == 20 and len(frames) == 80 and len(los) == 10 and len(derived) == 10
    _assert_los_arrows(los, tmp_path / "run" / "ekf_on")
    _assert_derived_series(derived, tmp_path / "run" / "ekf_on")
    _assert_layout_names_the_runs_topics(tmp_path / "run" / "ekf_on")
    _assert_same_as_bag(received, tmp_path / "run" / "ekf_on")
    _assert_frames_match_bag(frames, tmp_path / "run" / "ekf_on")

    # gimbal-bag play --live relays the bag it plays the same way. The replay is paced by the wall
    # clock, so it starts paused and plays once the client is connected: a client slow to start
    # under load would otherwise find the replay over.
    port = _free_port()
    play = subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(tmp_path / "run" / "ekf_on"), "--topics",
                             *TOPICS, "--playback-duration", "4", "--start-paused", "--live", "--live-port", str(port)],
                            env=ros_domain_env, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    client = None
    try:
        _wait_listening(port, play)
        client = subprocess.Popen(["node", str(node_client), f"ws://127.0.0.1:{port}", LEGACY_SUBPROTOCOL.decode(),
                                   "5", *TOPICS], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        opened = client.stdout.readline()  # connected; it subscribes on the advertisement that follows
        play.stdin.write("\n")
        play.stdin.flush()
        rest, client_err = client.communicate(timeout=120)
        output, _ = play.communicate(timeout=120)
    finally:
        for proc in (play, client):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
    assert play.returncode == 0, output
    assert client.returncode == 0 and json.loads(opened) == {"open": LEGACY_SUBPROTOCOL.decode()}, client_err
    replayed = [json.loads(line) for line in rest.splitlines()]
    assert len(replayed) == 10
    _assert_same_as_bag(replayed, tmp_path / "run" / "ekf_on")


def _assert_same_as_bag(received: list[dict], bag_dir: Path) -> None:
    messages, _ = read_messages(bag_dir, set(TOPICS))
    bag = {}
    for raw in messages:
        msg = TYPESTORE.deserialize_cdr(raw.data, raw.type_name)
        bag[(raw.topic, raw.log_time_ns)] = msg
    assert {m["topic"] for m in received} == set(TOPICS)
    for item in received:
        stamp = _stamp_ns(item["msg"])
        assert int(item["log_time"]) == stamp
        ref = bag[(item["topic"], stamp)]
        if item["topic"] == "/gimbal/imu":
            assert item["schema"] == "sensor_msgs/msg/Imu"
            got = item["msg"]["angular_velocity"]
            assert (got["x"], got["y"], got["z"]) == (ref.angular_velocity.x, ref.angular_velocity.y,
                                                      ref.angular_velocity.z)
            assert item["msg"]["header"]["frame_id"] == ref.header.frame_id
        else:
            assert item["schema"] == "geometry_msgs/msg/Vector3Stamped"
            got = item["msg"]["vector"]
            assert (got["x"], got["y"], got["z"]) == (ref.vector.x, ref.vector.y, ref.vector.z)




def _assert_derived_series(items: list[dict], bag_dir: Path) -> None:
    """The ±3σ bounds: the bag's bias and σ of the stamp. The LOS drift: recomputed here with
    scipy from the bag's true attitude, the first sample's LOS the reference, taken to the
    inertial frame with the earth rate at the site the report reads from scenario.yaml."""
    bag = {}
    for raw in read_messages(bag_dir, {"/gyro_bias_ekf/bias", "/gyro_bias_ekf/bias_sigma", "/truth/gimbal/imu"})[0]:
        bag[(raw.topic, raw.log_time_ns)] = TYPESTORE.deserialize_cdr(raw.data, raw.type_name)
    first = min(t for topic, t in bag if topic == "/truth/gimbal/imu")
    lat, earth_rate = vehicle_site(bag_dir)
    w_in = 7.292115e-5 * np.array([np.cos(lat), 0.0, -np.sin(lat)]) * earth_rate

    def inertial_az_el(t_ns: int) -> np.ndarray:
        o = bag[("/truth/gimbal/imu", t_ns)].orientation
        u = Rotation.from_rotvec(w_in * (t_ns - first) * 1e-9).apply(
            Rotation.from_quat([o.x, o.y, o.z, o.w]).apply([1.0, 0.0, 0.0]))
        return np.array([np.arctan2(u[1], u[0]), np.arcsin(-u[2])])

    az0, el0 = inertial_az_el(first)
    for item in items:
        msg = item["msg"]
        stamp = msg["header"]["stamp"]["sec"] * 1_000_000_000 + msg["header"]["stamp"]["nsec"]
        assert int(item["log_time"]) == stamp
        if item["topic"] == BOUNDS:
            bias, sigma = (bag[(t, stamp)].vector for t in ("/gyro_bias_ekf/bias", "/gyro_bias_ekf/bias_sigma"))
            for k in "yz":
                assert msg["upper"][k] == pytest.approx(getattr(bias, k) + 3 * getattr(sigma, k), rel=1e-12)
                assert msg["lower"][k] == pytest.approx(getattr(bias, k) - 3 * getattr(sigma, k), rel=1e-12)
        else:
            az, el = inertial_az_el(stamp)
            assert msg["azimuth_deg"] == pytest.approx(np.degrees((az - az0) * np.cos(el0)), abs=1e-9)
            assert msg["elevation_deg"] == pytest.approx(np.degrees(el - el0), abs=1e-9)


def _assert_layout_names_the_runs_topics(bag_dir: Path) -> None:
    """Every topic the shipped layout reads is one this run has: recorded (and its message
    has the field path the layout plots) or one of the live view's own channels."""
    layout = json.loads(LAYOUT.read_text())
    live = {FRAMES, LOS, DRIFT, BOUNDS}
    wanted = {p["value"].split(".")[0] for c in layout["configById"].values() for p in c.get("paths", [])} - live
    messages = {}
    for raw in stream(bag_dir, wanted):  # the first message of each
        if not isinstance(raw, BagContents):
            messages.setdefault(raw.topic, raw)
            if set(messages) == wanted:
                break
    recorded = {t["topic_metadata"]["name"] for t in
                yaml.safe_load((bag_dir / "metadata.yaml").read_text())["rosbag2_bagfile_information"]["topics_with_message_count"]}
    for config in layout["configById"].values():
        topics = set(config.get("topics", {})) | ({config["topicToRender"]} if "topicToRender" in config else set())
        assert topics <= recorded | live, topics
        for path in (p["value"] for p in config.get("paths", [])):
            topic, *fields = path.split(".")
            assert topic in messages or topic in live, path
            if topic in messages:
                value = TYPESTORE.deserialize_cdr(messages[topic].data, messages[topic].type_name)
                for field in fields:
                    value = getattr(value, field)
                assert isinstance(value, float), path


def _assert_los_arrows(items: list[dict], bag_dir: Path) -> None:
    """The LOS is the inner gimbal's x axis (spec §2): an arrow with the identity pose, locked
    to the true or the EKF's inner-gimbal frame, at the stamp of a message that moves it."""
    source = {"gimbal_inner_frd": "/truth/gimbal/joint_states", "ekf/gimbal_inner_frd": "/gyro_bias_ekf/attitude"}
    stamps = {(raw.topic, raw.log_time_ns) for raw in read_messages(bag_dir, set(source.values()))[0]}
    for item in items:
        assert item["schema"] == "foxglove.SceneUpdate"
        (entity,) = item["msg"]["entities"]
        stamp = entity["timestamp"]["sec"] * 1_000_000_000 + entity["timestamp"]["nsec"]
        assert int(item["log_time"]) == stamp and (source[entity["frame_id"]], stamp) in stamps
        assert entity["frame_locked"] is True
        (arrow,) = entity["arrows"]
        assert arrow["pose"] == {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
        assert arrow["shaft_length"] > 0 and arrow["head_length"] > 0


def _assert_frames_match_bag(frames: list[dict], bag_dir: Path) -> None:
    """Each transform against the bag's message at its stamp; the chain n→b→t→a→m, composed
    here, against the simulator's own C_nm on /truth/gimbal/imu."""
    sources = {"/truth/host/imu", "/truth/gimbal/joint_states", "/truth/gimbal/imu", "/gyro_bias_ekf/attitude"}
    bag = {(raw.topic, raw.log_time_ns): TYPESTORE.deserialize_cdr(raw.data, raw.type_name)
           for raw in read_messages(bag_dir, sources)[0]}

    def quat(o):
        return [o.x, o.y, o.z, o.w]

    by_stamp: dict[int, dict[tuple[str, str], Rotation]] = {}
    for item in frames:
        assert item["schema"] == "foxglove.FrameTransforms"
        for tf in item["msg"]["transforms"]:
            stamp = tf["timestamp"]["sec"] * 1_000_000_000 + tf["timestamp"]["nsec"]
            assert int(item["log_time"]) == stamp and tf["translation"] == {"x": 0.0, "y": 0.0, "z": 0.0}
            r = tf["rotation"]
            by_stamp.setdefault(stamp, {})[(tf["parent_frame_id"], tf["child_frame_id"])] = \
                Rotation.from_quat([r["x"], r["y"], r["z"], r["w"]])
    chains = ekfs = 0
    for stamp, tfs in by_stamp.items():
        if ("map_ned", "base_link_frd") in tfs:
            ref = Rotation.from_quat(quat(bag[("/truth/host/imu", stamp)].orientation))
            assert (tfs[("map_ned", "base_link_frd")].inv() * ref).magnitude() < 1e-12
        if ("map_ned", "ekf/gimbal_inner_frd") in tfs:
            ekfs += 1
            ref = Rotation.from_quat(quat(bag[("/gyro_bias_ekf/attitude", stamp)].orientation))
            assert (tfs[("map_ned", "ekf/gimbal_inner_frd")].inv() * ref).magnitude() < 1e-12
        links = [("base_link_frd", "turret_frd"), ("turret_frd", "gimbal_azimuth_frd"),
                 ("gimbal_azimuth_frd", "gimbal_inner_frd")]
        if all(link in tfs for link in links):
            joints = bag[("/truth/gimbal/joint_states", stamp)]
            angle = dict(zip(joints.name, joints.position))
            for link, axis, name in zip(links, "zzy", CHAIN):
                assert (tfs[link].inv() * Rotation.from_euler(axis, angle[name])).magnitude() < 1e-12
            if ("map_ned", "base_link_frd") in tfs:
                chains += 1
                composed = tfs[("map_ned", "base_link_frd")] * tfs[links[0]] * tfs[links[1]] * tfs[links[2]]
                ref = Rotation.from_quat(quat(bag[("/truth/gimbal/imu", stamp)].orientation))
                assert (composed.inv() * ref).magnitude() < 1e-9
    assert chains >= 1 and ekfs >= 1


def test_second_live_view_on_a_port_refused_before_anything_starts(tmp_path, ros_domain_env):
    with socket.socket() as taken:  # what a running live view holds
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        done = subprocess.run([str(VENV_BIN / "gimbal-run"), "gyro_at_rest", "--duration", "1", "--live",
                               "--live-port", str(port), "--out", str(tmp_path / "run")], env=ros_domain_env,
                              capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert f"port {port}" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "run").exists()


def test_bench_live_connects_a_client_and_finds_the_same_data(ros_domain_env):
    """``gimbal-bench live`` on short runs, two pairs (plain first, then live first): in each
    its client connects and receives, both bags hold the same data, and it prints the steps/s
    and the runs' CPU seconds of both runs; the median of two pairs is their mean."""
    port = _free_port()
    done = subprocess.run([str(VENV_BIN / "gimbal-bench"), "live", "--scenario", "sim_open_loop", "--duration", "0.5",
                           "--port", str(port), "--pairs", "2", "--mode", "container"], env=ros_domain_env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    rows = re.findall(r"^  (\d) +(plain, live|live, plain) +([\d,]+) +([\d,]+) +([+-][\d.]+)% +([\d.]+) +([\d.]+) "
                      r"+([+-][\d.]+)% +(\d+) +[\d.]+  same data", out, re.MULTILINE)
    assert [(r[0], r[1]) for r in rows] == [("1", "plain, live"), ("2", "live, plain")], out
    slowdowns = []
    for row in rows:
        plain, live = (float(v.replace(",", "")) for v in row[2:4])
        assert plain > 0 and live > 0 and float(row[5]) > 0 and float(row[6]) > 0 and int(row[8]) > 0, out
        # the printed steps/s are rounded to 1: 100 (p/l − 1) moves by up to 50 (1/l + p/l²), the % by 0.05
        rounding = 50.0 * (1.0 / live + plain / live ** 2)
        assert float(row[4]) == pytest.approx(100 * (plain / live - 1), abs=0.1 + rounding)
        slowdowns.append(float(row[4]))
    median = re.search(r"median slowdown ([+-][\d.]+)% \(target <= \+10%\)", out)
    assert median and float(median.group(1)) == pytest.approx(sum(slowdowns) / 2, abs=0.11), out
    assert "client: connected in 2 of 2 pairs" in out and "bags: same data in 2 of 2 pairs" in out


def test_front_renames_only_the_legacy_offer():
    request = (b"GET / HTTP/1.1\r\nHost: x\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n")
    rewritten, legacy = _offered_legacy(request)
    assert legacy and b"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n" in rewritten
    both = b"GET / HTTP/1.1\r\nsec-websocket-protocol: foxglove.websocket.v1, foxglove.sdk.v1\r\n\r\n"
    assert _offered_legacy(both) == (both, False)
    other = b"GET / HTTP/1.1\r\nSec-WebSocket-Protocol: chat\r\n\r\n"
    assert _offered_legacy(other) == (other, False)


def test_topic_rates_parsed_and_bad_ones_refused():
    assert parse_topic_rates(["/gimbal/imu=100", "/clock=0"]) == {"/gimbal/imu": 100.0, "/clock": 0.0}
    for bad in ("/gimbal/imu", "gimbal/imu=5", "/x=-1", "/x=nan", "/x=inf", "/x=fast"):
        with pytest.raises(ValueError, match="TOPIC=HZ"):
            parse_topic_rates([bad])
