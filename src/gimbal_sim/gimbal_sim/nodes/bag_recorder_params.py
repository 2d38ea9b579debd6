"""The ``bag_recorder`` node's parameter table and --help text, readable without ROS (the
node declares them; the config generator and the scenario checks read them).
"""
from __future__ import annotations

from gimbal_kinematics.params import Param

DESCRIPTION = (
    "Record topics, serialized and unchanged, into a rosbag2-style bag (metadata.yaml + MCAP, "
    "profile ros2, ros2msg schemas, cdr) logged in sim time. Takes part in the run's readiness "
    "and pacing so that no step is missed."
)
PARAMS = (
    Param("output_dir", "", "bag directory to write (refused if it already holds a bag)"),
    Param("topics", [], "topics to record; empty: every topic discovered", array_type="string_array"),
    Param("exclude_topics", ["/rosout", "/parameter_events"], "topics never recorded"),
    Param("wait_for_nodes", [], "with topics empty: node names whose publishers must all be subscribed "
          "before ready", array_type="string_array"),
    Param("sim_rate_hz", 1000.0, "simulation rate [Hz], to turn /clock into step numbers", 1.0, 100000.0),
    Param("progress_every_steps", 10, "report the next step needed on ~/progress every N steps", 1, 10**6),
    Param("end_time_s", 0.0, "sim time of the run's last step [s]: reaching it on /clock is reported on "
          "~/progress at once (0: unknown)", 0.0, 1e9),
    Param("record_topic_rates", [], "per-topic record rates 'TOPIC=HZ', by stamp: a topic's first message, then "
          "each one at least 1/HZ after the last kept (0: every message); for runs of hours",
          array_type="string_array"),
    Param("compress", True, "zstd-compress the MCAP chunks (false: store them uncompressed)"),
    Param("chunk_duration_s", 0.5, "finish and flush an MCAP chunk at least every this much log time [s]",
          1e-3, 60.0),
    Param("live_port", 0, "serve a live view (Foxglove WebSocket) on this TCP port; 0: no live view", 0, 65535),
    Param("live_host", "127.0.0.1", "address the live view listens on"),
    Param("live_rate_hz", 50.0, "default rate each topic is relayed at, decimated by stamp [Hz]; 0: every message",
          0.0, 1e6),
    Param("live_topic_rates", [], "per-topic relay rates 'TOPIC=HZ' (0: every message)", array_type="string_array"),
)
