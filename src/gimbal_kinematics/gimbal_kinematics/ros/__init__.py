"""The shared ROS edge of every node (the only part of gimbal_kinematics that imports rclpy or
message packages): node ``main``, QoS profiles, parameter declaration, readiness, the CDR
codec, ROS domain claims and the base message conversions. Import its modules explicitly
(``from gimbal_kinematics.ros.qos import ...``); this ``__init__`` imports nothing, so the
pure modules of the package never pull rclpy in."""
