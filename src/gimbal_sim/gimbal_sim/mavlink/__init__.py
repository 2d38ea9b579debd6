"""MAVLink Gimbal Protocol v2 on the graph: ``mavlink_gimbal_device`` presents the simulated
two-axis gimbal as a gimbal device, ``mavlink_gimbal_manager`` drives a real one. The
protocol logic lives in rclpy-free cores (:mod:`.device_core`, :mod:`.manager_core`) that
take and return datagrams; the nodes only move bytes between UDP (:mod:`.link`) and topics."""
