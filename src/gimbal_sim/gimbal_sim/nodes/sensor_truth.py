"""The ``sensor_models`` node's topic tables (the truth each sensor needs, the topics each
publishes) and the truth a step's group of truth messages carries (:func:`truth_from_group`)."""
from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu, JointState, NavSatFix

from gimbal_kinematics.maths.rotations import euler321_from_quat
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros import wire as w
from ..world.vehicle import VehicleTruth

#: Truth topic -> message type; which ones a run needs follows from the enabled sensors.
TRUTH_TOPICS = {
    "/truth/host/imu": Imu,
    "/truth/host/delta_angle": Vector3Stamped,
    "/truth/gimbal/imu": Imu,
    "/truth/gimbal/joint_states": JointState,
    "/truth/platform/imu": Imu,
    "/truth/platform/joint_states": JointState,
}
DECODERS = {Imu: m.imu_from_cdr, JointState: m.joint_state_from_cdr, Vector3Stamped: m.vector3_stamped_from_cdr}
NEEDS = {
    "ins": ("/truth/host/imu",),
    "gimbal_gyro": ("/truth/gimbal/imu",),
    "encoders": ("/truth/gimbal/joint_states",),
    "lgu": ("/truth/host/delta_angle",),
    "platform_imu": ("/truth/platform/imu",),
    "free_gyro": ("/truth/host/imu", "/truth/host/delta_angle"),
    "resolvers": ("/truth/platform/joint_states",),
    "dtg": ("/truth/platform/imu", "/truth/platform/joint_states"),
}

#: sensor -> the topics (and types) its samples are published on (:func:`.wire.sensor_messages`)
SENSOR_TOPICS = {
    "ins": (("/ins/imu", w.IMU), ("/truth/ins/gyro_bias", w.VECTOR3_STAMPED)),
    "gimbal_gyro": (("/gimbal/imu", w.IMU), ("/truth/gimbal/gyro_bias", w.VECTOR3_STAMPED)),
    "encoders": (("/gimbal/joint_states", w.JOINT_STATE),),
    "lgu": (("/ship/lgu1/imu", w.IMU), ("/ship/lgu2/imu", w.IMU), ("/truth/ship/flexure", w.VECTOR3_STAMPED),
            ("/truth/ship/flexure_quasi_static", w.VECTOR3_STAMPED)),
    "platform_imu": (("/platform/imu", w.IMU), ("/truth/platform/accel_bias", w.VECTOR3_STAMPED),
                     ("/truth/platform/gyro_bias", w.VECTOR3_STAMPED)),
    "free_gyro": (("/free_gyro/spin_axis_a", w.VECTOR3_STAMPED), ("/free_gyro/spin_axis_b", w.VECTOR3_STAMPED),
                  ("/free_gyro/imu", w.IMU), ("/truth/free_gyro/position", w.NAVSAT_FIX),
                  ("/truth/free_gyro/triad_bias", w.VECTOR3_STAMPED), ("/free_gyro/velocity", w.VECTOR3_STAMPED)),
    "resolvers": (("/platform/resolvers", w.JOINT_STATE),),
    "dtg": (("/platform/dtg_pickoffs", w.JOINT_STATE),),
}
TYPES = {w.IMU: Imu, w.JOINT_STATE: JointState, w.VECTOR3_STAMPED: Vector3Stamped, w.NAVSAT_FIX: NavSatFix}


def truth_from_group(k: int, t: float, group: dict) -> VehicleTruth:
    """A :class:`VehicleTruth` holding what the subscribed truth topics carry."""
    host = group.get("/truth/host/imu")
    plant = group.get("/truth/gimbal/imu") or group.get("/truth/platform/imu")
    joints = group.get("/truth/gimbal/joint_states") or group.get("/truth/platform/joint_states")
    delta = group.get("/truth/host/delta_angle")
    return VehicleTruth(
        k=k, t=t,
        euler=euler321_from_quat(m.quat_of(host)) if host is not None else (0.0, 0.0, 0.0),
        quat_nb=m.quat_of(host) if host is not None else None,
        omega_ib_b=m.vec_of(host.angular_velocity) if host is not None else None,
        specific_force_b=m.vec_of(host.linear_acceleration) if host is not None else None,
        delta_angle_b=m.vec_of(delta.vector) if delta is not None else None,
        joint_names=tuple(joints.name) if joints is not None else (),
        joint_position=tuple(joints.position) if joints is not None else (),
        joint_velocity=tuple(joints.velocity) if joints is not None else (),
        joint_effort=tuple(joints.effort) if joints is not None else (),
        quat_nm=m.quat_of(plant) if plant is not None else None,
        omega_im_m=m.vec_of(plant.angular_velocity) if plant is not None else None,
        specific_force_m=m.vec_of(plant.linear_acceleration) if plant is not None else None,
    )
