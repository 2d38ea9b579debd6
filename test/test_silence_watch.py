"""A lockstep node that hears inputs but gets no step grid says so (the pure policies, with an
injected clock), and a run's saved params files leave the orchestrator's timing out."""
from __future__ import annotations

from pathlib import Path

import yaml

from gimbal_kinematics.timing.control_policy import LockstepControl
from gimbal_kinematics.timing.input_policy import LockstepOrder
from gimbal_kinematics.timing.stream_stats import SILENCE_S, SilenceWatch
from gimbal_sim.graph.plan import plan_nodes, write_run_files
from gimbal_sim.graph.scenario import load


class FakeClock:
    def __init__(self) -> None:
        self.ns = 0

    def __call__(self) -> int:
        return self.ns


def _feed(policy, clock: FakeClock, kind: str, seconds: float, every_s: float = 0.1) -> list[str]:
    """Inputs of ``kind`` every ``every_s`` of clock time; the alarms the watch raised."""
    alarms = []
    for i in range(int(round(seconds / every_s))):
        clock.ns += int(every_s * 1e9)
        policy.add(kind, 1_000_000 * (i + 1), object())
        text = policy.silence.take()
        if text:
            alarms.append((clock.ns * 1e-9, text))
    return alarms


def test_inputs_without_a_step_raise_one_alarm_naming_timing_after_the_silence():
    clock = FakeClock()
    # a controller whose steps need the gyro and the step grid (/clock ticks): only the gyro comes
    policy = LockstepControl(lambda k: ("gyro", "clock"), rate_hz=1000.0, clock_jump_s=1.0)
    policy.silence = SilenceWatch(now_ns=clock)
    alarms = _feed(policy, clock, "gyro", 3 * SILENCE_S)
    assert len(alarms) == 1
    when, text = alarms[0]
    assert SILENCE_S <= when <= SILENCE_S + 0.1 + 1e-9  # the first input at 0.1 s
    assert "'timing'" in text and "timing:=free" in text


def test_a_released_step_clears_the_silence():
    clock = FakeClock()
    watch = SilenceWatch(after_s=1.0, now_ns=clock)
    for _ in range(9):  # 0.9 s of inputs without a step, then a step
        clock.ns += 100_000_000
        assert watch.heard(0) is None
    assert watch.heard(1) is None
    for _ in range(9):  # the silence starts over
        clock.ns += 100_000_000
        assert watch.heard(0) is None
    clock.ns += 200_000_000
    assert watch.heard(0) is not None and watch.heard(0) is None  # once per silence


def test_an_ordered_lockstep_node_with_a_stream_missing_raises_the_alarm():
    clock = FakeClock()
    policy = LockstepOrder(("encoders", "gyro"), max_wait_ns=10**15, rate_hz=100.0, progress_every=1)
    policy.silence = SilenceWatch(now_ns=clock)
    assert len(_feed(policy, clock, "gyro", 2 * SILENCE_S)) == 1


def test_saved_params_files_hold_no_orchestrator_timing(tmp_path: Path):
    scenario = load("sighting_land_vehicle")
    nodes = plan_nodes(scenario, tmp_path / "bag")
    write_run_files(scenario, nodes, tmp_path)
    ekf = next(n for n in nodes if n.name == "gyro_bias_ekf")
    saved = yaml.safe_load((tmp_path / "params" / "gyro_bias_ekf.yaml").read_text())["gyro_bias_ekf"]
    assert "timing" not in saved["ros__parameters"]
    # the graph still runs it in lockstep: the orchestrator passes the timing on the command line
    args = ekf.ros_args()
    assert args[args.index("-p") + 1] == "timing:=lockstep" and ekf.params["timing"] == "lockstep"
    # a scenario's own timing is the node's configuration: it stays in the file
    free = load("sighting_realtime")
    chosen = {n: s["params"]["timing"] for n, s in free.nodes.items() if "timing" in s["params"]}
    assert chosen
    planned = plan_nodes(free, tmp_path / "bag2")
    write_run_files(free, planned, tmp_path / "run2")
    for name, timing in chosen.items():
        doc = yaml.safe_load((tmp_path / "run2" / "params" / f"{name}.yaml").read_text())
        assert doc[name]["ros__parameters"]["timing"] == timing


def test_a_lockstep_node_started_alone_says_it_gets_no_step(ros_domain_env, tmp_path):
    """A controller told timing:=lockstep hears gyro samples (nothing else, no /clock) and
    releases no step: within a few seconds it logs a warning naming the parameter."""
    import subprocess

    from sensor_msgs.msg import Imu

    from conftest import VENV_BIN
    from gimbal_kinematics.ros.qos import GRAPH_QOS
    from gimbal_sim.graph.orchestrator import stop_processes
    from ros_harness import harness_node, spin_until

    log_path = tmp_path / "node.log"
    with open(log_path, "w") as log:
        proc = subprocess.Popen([str(VENV_BIN / "los_rate_controller"), "--ros-args", "-p", "timing:=lockstep"],
                                env=ros_domain_env, stdout=log, stderr=subprocess.STDOUT)
        try:
            with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"]), "gyro_feeder") as (node, executor):
                pub = node.create_publisher(Imu, "/gimbal/imu", GRAPH_QOS)
                assert spin_until(executor, lambda: pub.get_subscription_count() > 0, 60.0)
                sent = [0]

                def publish_and_check() -> bool:
                    msg = Imu()
                    sent[0] += 1
                    msg.header.stamp.nanosec = sent[0] * 1_000_000  # 1 kHz steps, never complete
                    pub.publish(msg)
                    return "parameter 'timing'" in log_path.read_text()
                # the warning comes SILENCE_S after the first sample; the bound is for a loaded machine
                assert spin_until(executor, publish_and_check, 6 * SILENCE_S), log_path.read_text()[-2000:]
        finally:
            stop_processes([proc])
    assert "timing:=free" in log_path.read_text()
