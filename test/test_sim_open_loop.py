"""Open loop: the ship (paper 5) with its two LGUs, vehicle free-running at full speed.

No controller gates the steps, so only the readiness/pacing protocol keeps sensor_models
and the test's reader from missing any: the reader paces the vehicle too, as a recorder
would (a reader that falls more than its history depth behind loses the oldest samples). Every LGU message must arrive, in order, equal to
the sensor suite run in-process on the same truth.
"""
from __future__ import annotations

import pytest
from geometry_msgs.msg import Vector3Stamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_sim.nodes.sensor_models_node import truth_from_group
from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros

RATE_HZ, LGU_HZ, DURATION_S, SEED = 200.0, 50.0, 6.0, 77
STEPS = int(RATE_HZ * DURATION_S)
LGU_COUNT = int(DURATION_S * LGU_HZ)  # no sample at k = 0: an increment needs an interval
TOPICS = {"/ship/lgu1/imu": Imu, "/ship/lgu2/imu": Imu, "/truth/ship/flexure": Vector3Stamped,
          "/truth/ship/flexure_quasi_static": Vector3Stamped, "/clock": Clock}


def test_open_loop_ship_delivers_every_lgu_sample(ros_domain_env, tmp_path):
    vehicle = {"profile": "paper5_ship", "plant": "host_only", "sim_rate_hz": RATE_HZ, "duration_s": DURATION_S,
               "pace_topics": ["/sensor_models/progress", "/test_reader/progress"], "pace_window_steps": 20,
               "wait_for_subscribers": 0}
    sensors = {"sensors": ["lgu"], "sim_rate_hz": RATE_HZ, "lgu_rate_hz": LGU_HZ, "seed": SEED,
               "wait_for_subscribers": 1}
    got = {t: [] for t in TOPICS}
    lgu_topics = [t for t in TOPICS if t != "/clock"]
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        progress = node.create_publisher(Clock, "/test_reader/progress", GRAPH_QOS)
        progress.publish(m.clock_msg(0))

        def on_message(topic, msg):
            got[topic].append(msg)
            if topic != "/clock":  # next step needed: one after the oldest of the newest LGU samples
                newest = [m.step_of_stamp(m.stamp_ns(got[t][-1].header.stamp), RATE_HZ) if got[t] else -1
                          for t in lgu_topics]
                progress.publish(m.clock_msg(m.step_stamp_ns(min(newest) + 1, RATE_HZ)))

        for topic, typ in TOPICS.items():
            node.create_subscription(typ, topic, lambda msg, t=topic: on_message(t, msg), GRAPH_QOS)
        with node_processes([("sensor_models", sensors), ("vehicle_dynamics", vehicle)], ros_domain_env, tmp_path):
            # the reader paces on the LGU samples only: it may miss /clock steps in between
            # (keep-last history), never the run's end or an LGU sample
            counts = {t: LGU_COUNT for t in lgu_topics}
            end_ns = m.step_stamp_ns(STEPS, RATE_HZ)
            assert spin_until(executor, lambda: all(len(got[t]) >= n for t, n in counts.items())
                              and got["/clock"] and m.stamp_ns(got["/clock"][-1].clock) == end_ns,
                              timeout_s=120.0), {t: len(v) for t, v in got.items()}
    assert {t: len(v) for t, v in got.items() if t != "/clock"} == counts

    core = VehicleCore(VehicleConfig(profile="paper5_ship", plant="host_only", sim_rate_hz=RATE_HZ,
                                     duration_s=DURATION_S))
    suite = SensorSuite(SensorSuiteConfig(sensors=("lgu",), sim_rate_hz=RATE_HZ, lgu_rate_hz=LGU_HZ, seed=SEED))
    expected = []
    for k in range(STEPS + 1):
        truth = core.truth()
        delta = m.vector3_msg(m.step_stamp_ns(k, RATE_HZ), "base_link_frd", truth.delta_angle_b)
        expected += suite.update(truth_from_group(k, k / RATE_HZ, {"/truth/host/delta_angle": delta}))
        if k < STEPS:
            core.step(())
    assert len(expected) == LGU_COUNT
    for msg1, msg2, flex, want in zip(got["/ship/lgu1/imu"], got["/ship/lgu2/imu"], got["/truth/ship/flexure"],
                                      expected, strict=True):
        assert m.stamp_ns(msg1.header.stamp) == m.step_stamp_ns(round(want.t * RATE_HZ), RATE_HZ)
        assert m.vec_of(msg1.angular_velocity) == tuple(d / want.dt for d in want.dalpha1)
        assert m.vec_of(msg2.angular_velocity) == tuple(d / want.dt for d in want.dalpha2)
        assert m.vec_of(flex.vector) == want.flexure
