"""The ``bag_recorder`` node's parameters and --help text, declared once in
:class:`BagRecorderNodeParams`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import declaration, param


@dataclass(frozen=True)
class BagRecorderNodeParams:
    """Record topics, serialized and unchanged, into a rosbag2-style bag (metadata.yaml + MCAP, profile ros2,
    ros2msg schemas, cdr) logged in sim time. Takes part in the run's readiness and pacing so that no step is
    missed.
    """

    output_dir: str = param("", "bag directory to write (refused if it already holds a bag)")
    topics: tuple[str, ...] = param((), "topics to record; empty: every topic discovered", array_type="string_array")
    exclude_topics: tuple[str, ...] = param(("/rosout", "/parameter_events"), "topics never recorded")
    wait_for_nodes: tuple[str, ...] = param((), "with topics empty: node names whose publishers must all be "
        "subscribed before ready", array_type="string_array")
    sim_rate_hz: float = param(1000.0, "simulation rate, to turn /clock into step numbers", 1.0, 100000.0, unit="Hz")
    progress_every_steps: int = param(10, "report the next step needed on ~/progress every N steps", 1, 10**6)
    end_time_s: float = param(0.0, "sim time of the run's last step: reaching it on /clock is reported on ~/progress "
        "at once (0: unknown)", 0.0, 1e9, unit="s")
    record_topic_rates: tuple[str, ...] = param((), "per-topic record rates 'TOPIC=HZ', by stamp: a topic's first "
        "message, then each one at least 1/HZ after the last kept (0: every message); for runs of hours",
        array_type="string_array")
    compress: bool = param(True, "zstd-compress the MCAP chunks (false: store them uncompressed)")
    chunk_duration_s: float = param(0.5, "finish and flush an MCAP chunk at least every this much log time",
        1e-3, 60.0, unit="s")
    live_port: int = param(0, "serve a live view (Foxglove WebSocket) on this TCP port; 0: no live view", 0, 65535)
    live_host: str = param("127.0.0.1", "address the live view listens on")
    live_rate_hz: float = param(50.0, "default rate each topic is relayed at, decimated by stamp; 0: every message",
        0.0, 1e6, unit="Hz")
    live_topic_rates: tuple[str, ...] = param((), "per-topic relay rates 'TOPIC=HZ' (0: every message)",
        array_type="string_array")


PARAMS, DESCRIPTION = declaration(BagRecorderNodeParams)
