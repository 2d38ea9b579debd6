"""The one QoS profile of the simulation graph's topics.

Reliable, so lockstep never loses a step. TRANSIENT_LOCAL with a 100-sample history,
because discovery is asynchronous: a reader whose subscription matches a writer a few
steps late (a controller or recorder started with the run) still receives those steps.
Nothing runs more than ``depth`` steps ahead of a reader (lockstep or pacing), so the
history never overflows. Volatile subscribers (e.g. a user's own tools) stay compatible.
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

GRAPH_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

#: The ros2_control command contract (:data:`gimbal_kinematics.params.table.COMMAND_INTERFACE_PARAM`):
#: topic_based_ros2_control publishes its joint commands reliable and volatile
#: (``rclcpp::QoS(1)``), so a subscription to them must be volatile (a transient-local reader
#: refuses a volatile writer). Ours keep 100 samples on either side: the depth does not
#: enter matching, and a lockstep reader (the recorder) that acknowledges late loses nothing.
ROS2_CONTROL_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
