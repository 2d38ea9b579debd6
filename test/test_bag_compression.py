"""zstd-compressed bags (the recorder's default) against --no-compress: a third of the size
or less, and the same data and figures through our reports, ``rosbags`` and ``mcap``."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from gimbal_sim.bag.compare import compare_bags
from gimbal_sim.bag.reader import find_mcap, read_messages
from gimbal_sim.campaign.results import flatten_metrics
from gimbal_sim.reports.sighting import load_sighting_series

BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def bags(tmp_path_factory, module_ros_domain_env) -> dict[str, Path]:
    """The same 2 s sighting_land_vehicle:ekf_on run recorded compressed and uncompressed (the
    size ratio is a property of the message stream, not of its length: 3.9 at 2 s and at 5 s)."""
    root = tmp_path_factory.mktemp("compression")
    out = {}
    for name, extra in (("zstd", []), ("plain", ["--no-compress"])):
        result = subprocess.run([str(BIN / "gimbal-run"), "sighting_land_vehicle", "--variant", "ekf_on", "--seed", "4",
                                 "--duration", "2", "--mode", "container", "--no-progress", "--out", str(root / name),
                                 *extra], env=module_ros_domain_env, capture_output=True, text=True, timeout=600)
        assert result.returncode == 0, result.stderr[-3000:]
        out[name] = root / name / "ekf_on"
    return out


@pytest.mark.ros
def test_compressed_bag_is_at_most_a_third_and_its_chunks_are_zstd(bags):
    sizes = {name: find_mcap(bag)[0].stat().st_size for name, bag in bags.items()}
    assert sizes["zstd"] * 3 <= sizes["plain"], sizes
    for name, expected in (("zstd", {"zstd"}), ("plain", {""})):
        with open(find_mcap(bags[name])[0], "rb") as f:
            assert {c.compression for c in make_reader(f).get_summary().chunk_indexes} == expected
    assert json.loads((bags["zstd"] / "run.json").read_text())["compressed"] is True


@pytest.mark.ros
def test_reports_rosbags_and_mcap_give_the_same_values_from_both(bags):
    reports = {name: flatten_metrics(json.loads((bag / "report" / "metrics.json").read_text()))
               for name, bag in bags.items()}
    assert json.dumps(reports["zstd"], sort_keys=True) == json.dumps(reports["plain"], sort_keys=True)
    assert compare_bags(bags["zstd"], bags["plain"]).byte_identical  # the mcap library, every payload and time
    seen = {}
    for name, bag in bags.items():
        with AnyReader([bag]) as reader:
            # log-time order; messages of one log time (two nodes' step-0 progress) in any order
            raw = sorted(((c.topic, t, bytes(data)) for c, t, data in reader.messages()),
                         key=lambda msg: (msg[1], msg[0], msg[2]))
            imu = [c for c in reader.connections if c.topic == "/truth/gimbal/imu"]
            last = None
            for c, _, data in reader.messages(connections=imu):
                last = reader.deserialize(data, c.msgtype).orientation
        seen[name] = (raw, (last.x, last.y, last.z, last.w))
    assert seen["zstd"][0] == seen["plain"][0]
    assert seen["zstd"][1] == seen["plain"][1]
    # and rosbags' reading of the truth equals what our reader hands the reports
    ours = load_sighting_series(bags["zstd"]).quat_nm[-1]
    assert tuple(ours) == seen["zstd"][1]
    ours_raw = [(m.topic, m.log_time_ns, m.data) for m in read_messages(bags["zstd"])[0]]
    assert sorted(ours_raw) == sorted(seen["plain"][0])
