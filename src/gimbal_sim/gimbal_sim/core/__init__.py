"""The no-ROS engine: a scenario's cores stepped in one Python loop, the same stages the
nodes run, with the same data for the same seed."""
