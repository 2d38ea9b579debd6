"""The simulated world, pure Python (no rclpy): the vehicle and gimbal plant, the sensors and
the sensor suite that samples them. Nodes and the core engine step these cores."""
