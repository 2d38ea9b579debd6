"""A node's parameters, readable without ROS: the :class:`~.table.Param` table every node
declares (``table``) and ROS 2 parameter files read as rcl reads them (``file``). Declaring
a table on an rclpy node is the ROS edge's job (:mod:`gimbal_kinematics.ros.params`)."""
