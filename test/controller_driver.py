"""A stand-in for a gimbal's drivers, in a process of its own, written with plain rclpy and
standard messages only (nothing of ours), as a user's drivers would be: it publishes
``/gimbal/imu`` (q, r: gyro bias + white noise; x marked with a large variance),
``/gimbal/joint_states`` and ``/ins/imu`` stamped with the wall clock at the time each sample
is due, with the given rates, stamp jitter and INS drops. The encoders can stop at a given
time. Writes the stamps it published (int ns, per topic) as JSON to ``--out`` at the end.

    python controller_driver.py --qos sensor_data --duration-s 3 --encoders-stop-s 2 --out f.json
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import Imu, JointState


def schedule(rate_hz: float, duration_s: float, jitter: float, drop: float, rng) -> list[float]:
    """Sample times [s] from the start: the k/rate grid, each moved by up to ±jitter of a
    period (uniform), a fraction ``drop`` left out."""
    n = int(duration_s * rate_hz)
    times = (np.arange(n) + rng.uniform(-jitter, jitter, n)) / rate_hz
    keep = rng.random(n) >= drop
    return [float(t) for t, k in zip(times, keep) if k and t >= 0.0]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--qos", choices=("sensor_data", "default"), required=True)
    ap.add_argument("--duration-s", type=float, required=True)
    ap.add_argument("--gyro-hz", type=float, default=200.0)
    ap.add_argument("--encoder-hz", type=float, default=100.0)
    ap.add_argument("--ins-hz", type=float, default=50.0)
    ap.add_argument("--jitter", type=float, default=0.2, help="stamp jitter, fraction of a period")
    ap.add_argument("--ins-drop", type=float, default=0.02)
    ap.add_argument("--encoders-stop-s", type=float, default=math.inf)
    ap.add_argument("--bias-deg-h", type=float, default=100.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    qos = qos_profile_sensor_data if args.qos == "sensor_data" else QoSProfile(depth=10)
    rclpy.init()
    node = rclpy.create_node("gimbal_driver_stand_in")
    pubs = {"gyro": node.create_publisher(Imu, "/gimbal/imu", qos),
            "enc": node.create_publisher(JointState, "/gimbal/joint_states", qos),
            "ins": node.create_publisher(Imu, "/ins/imu", qos)}
    events = [(t, "gyro") for t in schedule(args.gyro_hz, args.duration_s, args.jitter, 0.0, rng)]
    events += [(t, "enc") for t in schedule(args.encoder_hz, args.duration_s, args.jitter, 0.0, rng)
               if t < args.encoders_stop_s]
    events += [(t, "ins") for t in schedule(args.ins_hz, args.duration_s, args.jitter, args.ins_drop, rng)]
    events.sort()
    bias = math.radians(args.bias_deg_h / 3600.0)
    sigma = 1e-3  # rad/s white noise per sample
    # wait for the controller to discover us (every publisher matched), at most 20 s
    deadline = time.monotonic() + 20.0
    while any(p.get_subscription_count() == 0 for p in pubs.values()) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    t0 = time.time_ns()
    published: dict[str, list[int]] = {k: [] for k in pubs}
    for t, kind in events:
        stamp = t0 + int(round(t * 1e9))
        delay = (stamp - time.time_ns()) * 1e-9
        if delay > 0:
            time.sleep(delay)
        sec, nsec = divmod(stamp, 1_000_000_000)
        if kind == "enc":
            msg = JointState(name=["turret_azimuth", "gimbal_azimuth", "gimbal_elevation"],
                             position=[0.1, 0.2, 0.05], velocity=[0.0, 0.0, 0.0])
        else:
            msg = Imu()
            if kind == "gyro":
                msg.orientation_covariance[0] = -1.0
                msg.angular_velocity.y, msg.angular_velocity.z = bias + sigma * rng.standard_normal(2)
                msg.angular_velocity_covariance = [1e6, 0.0, 0.0, 0.0, sigma**2, 0.0, 0.0, 0.0, sigma**2]
            else:
                msg.orientation.w = 1.0
                msg.orientation_covariance = [1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6]
                msg.angular_velocity_covariance = [1e-8, 0.0, 0.0, 0.0, 1e-8, 0.0, 0.0, 0.0, 1e-8]
            msg.linear_acceleration_covariance[0] = -1.0
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nsec
        pubs[kind].publish(msg)
        published[kind].append(stamp)
    time.sleep(0.5)  # let the last samples leave before the process goes
    with open(args.out, "w") as f:
        json.dump(published, f)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
