"""Geometry of stabilized sighting platforms (SPEC section 2). Pure numpy/scipy; no rclpy."""
