"""The one timing edge of every node (pure Python, no rclpy): the stamp vocabulary
(``stamps``), the orderings built on it (``sync``), a free-timing stream's statistics
(``stream_stats``), and the policies a node picks once in its constructor: the estimators'
input policies (``input_policy``) and the controllers' (``control_policy``). It imports only
the maths room below it; a core receives samples this room has checked and ordered."""
