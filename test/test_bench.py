"""gimbal-bench on a tiny run: the report has every figure it promises, the bags it
keeps hold the same data in both modes (read back with the mcap library), and the pure-core
loop computes the torque commands the graph recorded. No timing assertions."""
from __future__ import annotations

import re
import subprocess

import pytest
from mcap_ros2.reader import read_ros2_messages

from conftest import VENV_BIN
from gimbal_sim.bag.reader import find_mcap

pytestmark = pytest.mark.ros
DURATION_S = 0.2


@pytest.fixture(scope="module")
def bench(module_ros_domain_env, tmp_path_factory):
    keep = tmp_path_factory.mktemp("bench") / "runs"
    proc = subprocess.run([str(VENV_BIN / "gimbal-bench"), "--scenario", "los_stabilization", "--duration",
                           str(DURATION_S), "--memory", "--memory-factor", "2", "--keep", str(keep)],
                          env=module_ros_domain_env, capture_output=True, text=True, timeout=400)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout, proc.stderr, keep


def _row(out: str, label: str) -> list[str]:
    line = next(line for line in out.splitlines() if line.startswith(label))
    return line[len(label):].split()


def test_report_has_every_figure_for_each_mode(bench):
    out, err, _ = bench
    header = next(line for line in out.splitlines() if "(a) cores" in line)
    assert header.split() == ["(a)", "cores", "(b)", "container", "(c)", "processes"]
    for label in ("wall time (stepping) [s]", "real-time factor", "steps/s", "ratio to (a)", "step latency p50 [ms]",
                  "step latency p99 [ms]", "CPU, all processes [s]", "peak RSS, largest [MiB]", "messages recorded",
                  "messages lost"):
        values = _row(out, label)
        assert len(values) == 3, (label, values)
    steps = [float(v.replace(",", "")) for v in _row(out, "steps/s")]
    assert all(v > 0 for v in steps)
    assert _row(out, "ratio to (a)")[0] == "1.00x"
    assert _row(out, "messages lost")[1:] == ["0", "0"]
    # one CPU line per process of (c), each node and the recorder
    for name in ("core loop", "container", "vehicle_dynamics", "sensor_models", "los_rate_controller", "bag_recorder"):
        assert re.search(rf"\s{name}\s+[\d.]+ s\s+[\d.]+ % of a core", out), name
    # progress is one line per phase, not a bar
    assert len(err.splitlines()) < 40


def test_report_checks_data_replay_memory_and_targets(bench):
    out, _, _ = bench
    assert re.search(r"\(b\) and \(c\) recorded data\s+identical", out)  # the label column fits the longest row
    assert re.search(r"\(a\) against the bag\s+same torque commands as the graph at all \d+ steps", out)
    assert re.search(r"replay into gyro_bias_ekf \(core\)\s+[\d,.]+x real time", out)
    # gimbal-bag play --rate 0 into a free-timing node: every INS sample's estimate equal to the core's
    assert re.search(r"replay into gyro_bias_ekf \(node\)\s+[\d,.]+x real time .*; exact: every INS sample", out), \
        next((line for line in out.splitlines() if "(node)" in line), out)
    assert re.search(r"play into the EKF node >= 8x, exact\s+[\d,.]+x \(exact\)", out)
    assert re.search(r"RSS over 0.4 s \(2x\)\s+\S+", out)
    verdicts = [line for line in out.splitlines() if re.search(r"(met|NOT MET|not measured)$", line)]
    assert len(verdicts) >= 10
    assert re.search(r"messages delivered per step\s+[\d.]+ \(every topic's messages x", out)


def test_kept_bags_hold_the_same_data_in_both_modes(bench):
    _, _, keep = bench
    decoded = {}
    for mode in ("container", "processes"):
        mcap_path, _ = find_mcap(keep / mode)
        decoded[mode] = [(m.channel.topic, m.log_time_ns, m.ros_msg) for m in read_ros2_messages(str(mcap_path))]
    assert len(decoded["container"]) == len(decoded["processes"]) > 0
    key = lambda item: (item[0], item[1])  # noqa: E731
    for a, b in zip(sorted(decoded["container"], key=key), sorted(decoded["processes"], key=key)):
        # repr of a decoded message prints every float exactly (shortest round trip)
        assert (a[0], a[1], repr(a[2])) == (b[0], b[1], repr(b[2]))
    result = subprocess.run([str(VENV_BIN / "gimbal-bench"), "compare", str(keep / "container"),
                             str(keep / "processes")], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and "same data" in result.stdout
