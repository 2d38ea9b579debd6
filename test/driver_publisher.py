"""A stand-in for a user's drivers, written with plain rclpy and sensor_msgs only (no project
code): publishes a static two-axis gimbal's gyro, encoders and INS stamped with the wall
clock, listens to ``gyro_bias_ekf``'s ``~/bias`` and ``~/bias_sigma`` and writes them to a
JSON file.

Usage: python driver_publisher.py OUT.json --qos sensor_data|default --duration-s 60 --seed N

Truth (the test's closed form, computed here with scipy's Rotation):
* host static at latitude ``LAT_DEG``, C_nb from heading/pitch/roll ``HOST_YPR_DEG``
  (3-2-1), so the INS body rate is C_bn ω_ie^n;
* gimbal joints held at ``JOINTS_DEG`` (turret, gimbal azimuth, elevation):
  C_bm = Rz(ψt + ψm) Ry(θm), so the inner-gimbal rate is ω_im^m = C_mn ω_ie^n;
* gyro (y, z) = ω_im^m (y, z) + ``BIAS_DEG_H`` each + white noise of density
  ``GYRO_ARW_DEG_RT_H`` (σ = ARW / sqrt(dt) per sample); x = 0, unmeasured;
* gyro at 200 Hz with each interval uniform in ±20 % of 5 ms; encoders at 100 Hz with
  white noise ``ENC_NOISE_DEG``; INS at 50 Hz, 2 % of samples dropped at random, attitude
  with white noise ``INS_NOISE_DEG`` per angle, exact body rates.
* the gyro's unmeasured x axis: ``--qos sensor_data`` marks it with a very large variance
  (REP 145), ``--qos default`` sends an all-zero covariance ("unknown").
"""
from __future__ import annotations

import argparse
import heapq
import json
import math
import time

import numpy as np
from scipy.spatial.transform import Rotation

LAT_DEG = 45.0
HOST_YPR_DEG = (30.0, 2.0, -1.0)
JOINTS_DEG = (0.0, 20.0, 15.0)
BIAS_DEG_H = 100.0
GYRO_ARW_DEG_RT_H = 0.15
ENC_NOISE_DEG = 0.01
INS_NOISE_DEG = 0.01
EARTH_RATE = 7.292115e-5  # rad/s
GYRO_HZ, ENC_HZ, INS_HZ = 200.0, 100.0, 50.0
JITTER = 0.2
INS_DROP = 0.02
JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")


def truth():
    lat = math.radians(LAT_DEG)
    w_ie_n = EARTH_RATE * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    C_nb = Rotation.from_euler("ZYX", HOST_YPR_DEG, degrees=True)
    psi_t, psi_m, theta_m = (math.radians(a) for a in JOINTS_DEG)
    C_bm = Rotation.from_euler("ZY", [psi_t + psi_m, theta_m])
    C_nm = C_nb * C_bm
    return C_nb, C_nm.inv().apply(w_ie_n), C_nb.inv().apply(w_ie_n)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--qos", choices=("sensor_data", "default"), required=True)
    ap.add_argument("--duration-s", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Imu, JointState

    rng = np.random.default_rng(args.seed)
    C_nb, w_m, w_b = truth()
    q_nb = C_nb.as_quat()  # (x, y, z, w)
    bias = math.radians(BIAS_DEG_H / 3600.0)
    arw = math.radians(GYRO_ARW_DEG_RT_H) / 60.0  # rad/sqrt(s)

    rclpy.init()
    node = rclpy.create_node("driver_publisher")
    qos = qos_profile_sensor_data if args.qos == "sensor_data" else 10
    pub_g = node.create_publisher(Imu, "/gimbal/imu", qos)
    pub_e = node.create_publisher(JointState, "/gimbal/joint_states", qos)
    pub_i = node.create_publisher(Imu, "/ins/imu", qos)
    got: dict[str, list] = {"bias": [], "sigma": []}

    def keep(key):
        return lambda msg: got[key].append((msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
                                            msg.vector.x, msg.vector.y, msg.vector.z))

    node.create_subscription(Vector3Stamped, "/gyro_bias_ekf/bias", keep("bias"), 100)
    node.create_subscription(Vector3Stamped, "/gyro_bias_ekf/bias_sigma", keep("sigma"), 100)
    diagnostics: list[dict] = []
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda msg: diagnostics.extend(
        {kv.key: kv.value for kv in s.values} | {"level": int.from_bytes(s.level, "little") if isinstance(
            s.level, bytes) else int(s.level), "message": s.message} for s in msg.status), 100)
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline and not (
            all(p.get_subscription_count() >= 1 for p in (pub_g, pub_e, pub_i))
            and node.count_publishers("/gyro_bias_ekf/bias_sigma") >= 1):
        rclpy.spin_once(node, timeout_sec=0.05)
    if time.monotonic() >= deadline:
        raise SystemExit("the EKF did not appear")

    def stamp(msg, t_ns):
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(t_ns), 10**9)

    start = time.time_ns() + 200_000_000
    end = start + int(args.duration_s * 1e9)
    events = [(start, 0, "gyro"), (start, 1, "enc"), (start, 2, "ins")]
    last_gyro = None
    counts = {"gyro": 0, "enc": 0, "ins": 0, "ins_dropped": 0}
    while events:
        t_ns, order, kind = heapq.heappop(events)
        if t_ns > end:
            continue
        while (now := time.time_ns()) < t_ns:  # publish at the stamp's wall time
            rclpy.spin_once(node, timeout_sec=min(0.002, (t_ns - now) * 1e-9))
        if kind == "gyro":
            period = 1e9 / GYRO_HZ * (1.0 + rng.uniform(-JITTER, JITTER))
            dt = 1.0 / GYRO_HZ if last_gyro is None else (t_ns - last_gyro) * 1e-9
            last_gyro = t_ns
            noise = rng.normal(0.0, arw / math.sqrt(dt), 2)
            msg = Imu()
            msg.header.frame_id = "gimbal_inner_frd"
            msg.orientation_covariance[0] = -1.0
            msg.angular_velocity.y = w_m[1] + bias + noise[0]
            msg.angular_velocity.z = w_m[2] + bias + noise[1]
            if args.qos == "sensor_data":  # x unmeasured: a very large variance (REP 145)
                msg.angular_velocity_covariance = [1e6, 0, 0, 0, (arw**2) / dt, 0, 0, 0, (arw**2) / dt]
            # default: all zeros, "covariance unknown", as many drivers send
            msg.linear_acceleration_covariance[0] = -1.0
            stamp(msg, t_ns)
            pub_g.publish(msg)
            counts["gyro"] += 1
            heapq.heappush(events, (t_ns + int(period), 0, "gyro"))
        elif kind == "enc":
            msg = JointState()
            msg.name = list(JOINTS)
            msg.position = [math.radians(a + rng.normal(0.0, ENC_NOISE_DEG)) for a in JOINTS_DEG]
            msg.velocity = [0.0, 0.0, 0.0]
            stamp(msg, t_ns)
            pub_e.publish(msg)
            counts["enc"] += 1
            heapq.heappush(events, (t_ns + int(1e9 / ENC_HZ), 1, "enc"))
        else:
            if rng.uniform() < INS_DROP:
                counts["ins_dropped"] += 1
            else:
                err = Rotation.from_euler("ZYX", rng.normal(0.0, INS_NOISE_DEG, 3), degrees=True)
                q = (C_nb * err).as_quat()
                msg = Imu()
                msg.header.frame_id = "base_link_frd"
                msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = (float(v) for v in q)
                msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = (float(v) for v in w_b)
                msg.linear_acceleration_covariance[0] = -1.0
                stamp(msg, t_ns)
                pub_i.publish(msg)
                counts["ins"] += 1
            heapq.heappush(events, (t_ns + int(1e9 / INS_HZ), 2, "ins"))
    # the estimate of the last INS sample may still be on its way
    settle = time.monotonic() + 3.0
    while time.monotonic() < settle:
        rclpy.spin_once(node, timeout_sec=0.05)
    with open(args.out, "w") as f:
        json.dump({"start_ns": start, "end_ns": end, "bias_rad_s": bias, "q_nb": list(map(float, q_nb)),
                   "counts": counts, "diagnostics": diagnostics[-1:], **got}, f)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
