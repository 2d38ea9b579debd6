"""The node graph: the node registry, scenarios (``scenarios/*.yaml``), the node plan, the
generated config files, and the orchestrator that runs a scenario's nodes under ROS."""
