"""Read our bags, including truncated ones, and recover what a crash left.

The MCAP file is streamed record by record (``mcap.stream_reader``) rather than through its
summary, so a file cut short by a SIGKILL still yields every complete chunk; the first
incomplete or corrupt record ends the stream and is reported.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import yaml
from mcap.exceptions import McapError
from mcap.records import Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader

from .writer import BagWriter, TopicRecord


class BagError(ValueError):
    """The path is not a readable bag; the message says why."""


@dataclass
class RawMessage:
    topic: str
    type_name: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int


@dataclass
class BagContents:
    """What streaming a bag found: topics, counts, time span and whether it ended cleanly."""

    directory: Path
    mcap_path: Path
    has_metadata: bool
    complete: bool = False          # the MCAP ended with its footer
    error: str | None = None         # why the stream stopped early, if it did
    topics: dict[str, TopicRecord] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None

    @property
    def closed_cleanly(self) -> bool:
        return self.complete and self.has_metadata and self.error is None

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())


def find_mcap(directory: Path) -> tuple[Path, bool]:
    """The bag's MCAP file and whether ``metadata.yaml`` exists; raises :class:`BagError`."""
    directory = Path(directory)
    if not directory.exists():
        raise BagError(f"{directory}: no such file or directory")
    if not directory.is_dir():
        raise BagError(f"{directory}: not a bag directory (a bag is a directory with metadata.yaml and *.mcap)")
    meta = directory / "metadata.yaml"
    if meta.is_file():
        try:
            info = yaml.safe_load(meta.read_text())["rosbag2_bagfile_information"]
            files = [directory / f for f in info["relative_file_paths"]]
        except (yaml.YAMLError, KeyError, TypeError) as exc:
            raise BagError(f"{meta}: not rosbag2 metadata ({exc})") from exc
        if info.get("storage_identifier") != "mcap":
            raise BagError(f"{directory}: storage {info.get('storage_identifier')!r} is not mcap")
        if len(files) != 1 or not files[0].is_file():
            raise BagError(f"{directory}: metadata names {[f.name for f in files]}, expected one existing .mcap")
        return files[0], True
    found = sorted(directory.glob("*.mcap"))
    if len(found) != 1:
        raise BagError(f"{directory}: not a bag (no metadata.yaml and {len(found)} .mcap files)")
    return found[0], False


def stream(directory: Path, topics: set[str] | None = None) -> Iterator[RawMessage | BagContents]:
    """Yield every readable message (in file order), then the :class:`BagContents` summary."""
    mcap_path, has_metadata = find_mcap(directory)
    contents = BagContents(Path(directory), mcap_path, has_metadata)
    schemas: dict[int, str] = {}
    channels: dict[int, TopicRecord] = {}
    with open(mcap_path, "rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    pkg, _, name = schemas[record.schema_id].rpartition("/")
                    qos = yaml.safe_load(record.metadata.get("offered_qos_profiles", "") or "[]") or []
                    channels[record.id] = TopicRecord(record.topic, f"{pkg.split('/')[0]}/msg/{name}", qos, record.id)
                    contents.topics.setdefault(record.topic, TopicRecord(record.topic, channels[record.id].type_name,
                                                                         qos, record.id))
                elif isinstance(record, Message):
                    channel = channels[record.channel_id]
                    contents.topics[channel.name].count += 1
                    t = record.log_time
                    contents.start_ns = t if contents.start_ns is None else min(contents.start_ns, t)
                    contents.end_ns = t if contents.end_ns is None else max(contents.end_ns, t)
                    if topics is None or channel.name in topics:
                        yield RawMessage(channel.name, channel.type_name, record.data, t, record.publish_time)
                elif isinstance(record, Footer):
                    contents.complete = True
        except (McapError, EOFError, KeyError, ValueError, OSError) as exc:
            contents.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    if not contents.complete and contents.error is None:
        contents.error = "file ends before the MCAP footer (truncated)"
    yield contents


def scan(directory: Path) -> BagContents:
    """Counts, span and state of a bag without keeping its messages."""
    for item in stream(directory, topics=set()):
        if isinstance(item, BagContents):
            return item
    raise AssertionError("stream always ends with its summary")


def read_messages(directory: Path, topics: set[str] | None = None) -> tuple[list[RawMessage], BagContents]:
    messages: list[RawMessage] = []
    for item in stream(directory, topics):
        if isinstance(item, BagContents):
            return messages, item
        messages.append(item)
    raise AssertionError("stream always ends with its summary")


def recover(directory: Path, output: Path | None = None) -> tuple[Path, BagContents]:
    """Write every complete chunk's messages of a (truncated) bag to a new, valid bag.

    The new bag goes beside the old one (``<dir>_recovered``) unless ``output`` is given;
    an existing output is refused. Returns the new directory and what was read.
    """
    directory = Path(directory)
    output = Path(output) if output is not None else directory.with_name(directory.name + "_recovered")
    if output.exists():
        raise BagError(f"{output} already exists; not overwriting it")
    messages, contents = read_messages(directory)
    writer = BagWriter(output)
    for topic in contents.topics.values():
        writer.add_topic(topic.name, topic.type_name, topic.qos_profiles)
    for msg in messages:
        writer.write(msg.topic, msg.data, msg.log_time_ns, msg.publish_time_ns)
    writer.close()
    return output, contents
