"""gimbal_sim's own rclpy nodes (vehicle dynamics, sensor models, bag recorder), each a thin
node around a ``world`` or ``bag`` core, with its parameter table in ``<node>_params``."""
