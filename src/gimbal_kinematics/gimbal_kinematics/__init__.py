"""Geometry of stabilized sighting platforms (docs/spec.md section 2). Pure numpy/scipy; no rclpy."""
