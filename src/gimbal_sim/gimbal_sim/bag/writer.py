"""rosbag2-compatible bag writer: ``<dir>/metadata.yaml`` + ``<dir>/<name>_0.mcap``.

MCAP profile ``ros2``: ``ros2msg`` schemas (full definitions with dependencies), ``cdr``
message encoding, ``offered_qos_profiles`` in the channel metadata, log and publish times
in ns. Messages are written raw, as they came off the wire. Chunks are zstd-compressed by
default (``compress=False``: stored as they are); compression is inside the MCAP, per chunk,
so ``metadata.yaml`` names no rosbag2 compression and every MCAP reader (the ``mcap``
library, ``rosbags``, ``ros2 bag``, Foxglove) decompresses it itself.

Crash safety: the current chunk is finished and flushed to the OS whenever the log time
has advanced ``chunk_duration_ns`` past the last flush, or one wall second has passed, so
a SIGKILL loses at most that much. ``metadata.yaml`` is written by :meth:`close`; a bag
without it (or whose MCAP has no footer) was not closed cleanly.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from mcap.writer import CompressionType, Writer

from .qos_yaml import qos_yaml
from .schemas import ros2msg_schema

METADATA_VERSION = 9
ROS_DISTRO = "jazzy"
LIBRARY = "gimbal_sim bag writer (mcap python)"


@dataclass
class TopicRecord:
    name: str
    type_name: str
    qos_profiles: list[dict[str, Any]]
    channel_id: int
    count: int = 0


@dataclass
class BagWriter:
    """Write one bag directory; :meth:`close` finishes the MCAP and writes metadata."""

    directory: Path
    name: str | None = None
    chunk_duration_ns: int = 500_000_000
    #: zstd-compress each chunk (level 3, the mcap library's): about 5x smaller for our topics
    compress: bool = True
    wall_flush_s: float = 1.0
    topics: dict[str, TopicRecord] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.directory = Path(self.directory)
        existing = [p.name for p in self.directory.glob("*") if p.name == "metadata.yaml" or p.suffix == ".mcap"]
        if existing:
            raise FileExistsError(f"{self.directory} already holds a bag ({', '.join(existing)}); not overwriting it")
        self.directory.mkdir(parents=True, exist_ok=True)
        self.name = self.name or self.directory.name
        self.mcap_path = self.directory / f"{self.name}_0.mcap"
        self._file = open(self.mcap_path, "wb")
        self._writer = Writer(self._file, chunk_size=1 << 24,
                              compression=CompressionType.ZSTD if self.compress else CompressionType.NONE)
        self._writer.start(profile="ros2", library=LIBRARY)
        self._schemas: dict[str, int] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self._last_flush_ns = 0
        self._last_flush_wall = time.monotonic()
        self.closed = False

    def add_topic(self, topic: str, type_name: str, qos_profiles: list[dict[str, Any]]) -> None:
        """Register a topic before writing its messages (idempotent)."""
        if topic in self.topics:
            return
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            pkg, _, name = type_name.split("/")
            schema_id = self._writer.register_schema(
                name=f"{pkg}/msg/{name}", encoding="ros2msg", data=ros2msg_schema(type_name).encode())
            self._schemas[type_name] = schema_id
        channel_id = self._writer.register_channel(
            topic=topic, message_encoding="cdr", schema_id=schema_id,
            metadata={"offered_qos_profiles": qos_yaml(qos_profiles)})
        self.topics[topic] = TopicRecord(topic, type_name, qos_profiles, channel_id)

    def write(self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        record = self.topics[topic]
        self._writer.add_message(channel_id=record.channel_id, log_time=log_time_ns, data=data,
                                 publish_time=log_time_ns if publish_time_ns is None else publish_time_ns,
                                 sequence=record.count)
        record.count += 1
        if self._start_ns is None or log_time_ns < self._start_ns:
            self._start_ns = log_time_ns
        self._end_ns = max(self._end_ns, log_time_ns)
        if log_time_ns - self._last_flush_ns >= self.chunk_duration_ns or \
                time.monotonic() - self._last_flush_wall >= self.wall_flush_s:
            self.flush()

    def flush(self) -> None:
        """Finish the chunk in progress and hand it to the OS."""
        self._writer.flush()
        self._last_flush_ns = self._end_ns
        self._last_flush_wall = time.monotonic()

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def close(self) -> None:
        """Finish the MCAP (summary, footer) and write ``metadata.yaml``."""
        if self.closed:
            return
        self._writer.finish()
        self._file.close()
        self.closed = True
        write_metadata(self.directory, [self.mcap_path.name], list(self.topics.values()),
                       self._start_ns or 0, self._end_ns)


def write_metadata(directory: Path, files: list[str], topics: list[TopicRecord], start_ns: int, end_ns: int) -> None:
    """``metadata.yaml`` in rosbag2 format version 9."""
    count = sum(t.count for t in topics)
    duration = max(0, end_ns - start_ns)
    info = {
        "version": METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start_ns},
        "message_count": count,
        "topics_with_message_count": [
            {"topic_metadata": {"name": t.name, "type": t.type_name, "serialization_format": "cdr",
                                "offered_qos_profiles": t.qos_profiles, "type_description_hash": ""},
             "message_count": t.count}
            for t in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": files,
        "files": [{"path": f, "starting_time": {"nanoseconds_since_epoch": start_ns},
                   "duration": {"nanoseconds": duration}, "message_count": count} for f in files],
        "custom_data": {},
        "ros_distro": ROS_DISTRO,
    }
    text = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False, default_flow_style=False)
    tmp = directory / "metadata.yaml.tmp"
    tmp.write_text(text)
    tmp.replace(directory / "metadata.yaml")
