"""Rigid-body models of the hardware (pure numpy, no rclpy): the two-axis gimbal of paper 1
(mass properties, Newton-Euler dynamics about the pivot), the host state and the turret base
motion it sits on. The simulator integrates them; the controller inverts them."""
