"""Read any rosbag2 bag, including truncated ones, and recover what a crash left.

Two storages, as rosbag2 writes them:

* MCAP (ours, ``ros2 bag record``'s, ``rosbags``'s, any writer of the ``ros2`` profile;
  chunks uncompressed, zstd or lz4; one file or a split bag's several). Each file is
  streamed record by record (``mcap.stream_reader``) rather than through its summary, so a
  file cut short by a SIGKILL still yields every complete chunk; the first incomplete or
  corrupt record ends the stream and is reported.
* sqlite3 (``.db3``, the rosbag2 default before Iron): read through ``rosbags``
  (:mod:`.any_reader`), never by a parser of ours. A sqlite3 bag commits each row, so a
  killed recording loses no stored message but leaves no ``metadata.yaml``: rosbags then
  cannot open it, and the error says so (``ros2 bag reindex`` rebuilds the metadata).

Times are kept as the integer nanoseconds the bag stores (log time, and the header stamps
inside the CDR); an epoch start near 1.8e9 s costs no precision.
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
    mcap_path: Path                  # the (first) storage file: .mcap or .db3
    has_metadata: bool
    complete: bool = False          # every file ended with its footer (sqlite3: rosbags read it all)
    error: str | None = None         # why the stream stopped early, if it did
    topics: dict[str, TopicRecord] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None
    storage: str = "mcap"            # "mcap" or "sqlite3"
    metadata_required: bool = True   # False for a lone .mcap file: its footer and summary index it
    files: list[Path] = field(default_factory=list)
    compression: set[str] = field(default_factory=set)   # chunk compressions met ("" = none)

    @property
    def closed_cleanly(self) -> bool:
        return self.complete and (self.has_metadata or not self.metadata_required) and self.error is None

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def _count(self, topic: str, t_ns: int) -> None:
        self.topics[topic].count += 1
        self.start_ns = t_ns if self.start_ns is None else min(self.start_ns, t_ns)
        self.end_ns = t_ns if self.end_ns is None else max(self.end_ns, t_ns)


@dataclass(frozen=True)
class BagFiles:
    """Where a bag's messages are: its directory, storage and files in order."""

    directory: Path
    storage: str
    files: list[Path]
    has_metadata: bool
    metadata_required: bool = True


def locate(path: Path) -> BagFiles:
    """The storage files of the bag at ``path`` (a bag directory, or one .mcap/.db3 file);
    raises :class:`BagError` saying why it is not a readable bag."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"{path}: no such file or directory")
    if path.is_file():
        storage = {".mcap": "mcap", ".db3": "sqlite3"}.get(path.suffix)
        if storage is None:
            raise BagError(f"{path}: not a bag (give a bag directory, or its .mcap / .db3 file)")
        # a lone MCAP file (e.g. from a non-rosbag2 writer) is complete with its footer
        return BagFiles(path.parent, storage, [path], (path.parent / "metadata.yaml").is_file(),
                        metadata_required=storage != "mcap")
    meta = path / "metadata.yaml"
    if meta.is_file():
        try:
            info = yaml.safe_load(meta.read_text())["rosbag2_bagfile_information"]
            files = [path / f for f in info["relative_file_paths"]]
        except (yaml.YAMLError, KeyError, TypeError) as exc:
            raise BagError(f"{meta}: not rosbag2 metadata ({exc})") from exc
        storage = info.get("storage_identifier") or ("sqlite3" if files and files[0].suffix == ".db3" else "mcap")
        if storage not in ("mcap", "sqlite3"):
            raise BagError(f"{path}: storage {storage!r}: only mcap and sqlite3 bags can be read")
        missing = [f.name for f in files if not f.is_file()]
        if not files or missing:
            raise BagError(f"{path}: metadata names {[f.name for f in files]}, of which {missing or 'none'} "
                           f"do not exist")
        return BagFiles(path, storage, files, True)
    mcaps, db3s = sorted(path.glob("*.mcap")), sorted(path.glob("*.db3"))
    if mcaps and not db3s:
        return BagFiles(path, "mcap", mcaps, False)
    if db3s and not mcaps:
        raise BagError(f"{path}: a sqlite3 bag without metadata.yaml (a recording that was killed); "
                       f"`ros2 bag reindex {path}` rebuilds its metadata, then it can be read")
    raise BagError(f"{path}: not a bag (no metadata.yaml, {len(mcaps)} .mcap and {len(db3s)} .db3 files)")


def find_mcap(directory: Path) -> tuple[Path, bool]:
    """The bag's (first) MCAP file and whether ``metadata.yaml`` exists; raises :class:`BagError`."""
    found = locate(directory)
    if found.storage != "mcap":
        raise BagError(f"{directory}: a {found.storage} bag, not MCAP")
    return found.files[0], found.has_metadata


def _type_name(schema_name: str) -> str:
    """``pkg/msg/Name`` from an MCAP schema name (``pkg/msg/Name``, or ``pkg/Name`` from ROS 1 era writers)."""
    pkg, _, name = schema_name.rpartition("/")
    return f"{pkg.split('/')[0]}/msg/{name}"


def _stream_mcap(contents: BagContents, topics: set[str] | None) -> Iterator[RawMessage]:
    """Messages of every MCAP file of the bag in file order; sets ``contents`` as it goes."""
    contents.complete = True
    for path in contents.files:
        schemas: dict[int, str] = {}
        channels: dict[int, TopicRecord] = {}
        complete = False
        with open(path, "rb") as f:
            try:
                for record in StreamReader(f, validate_crcs=True).records:
                    if isinstance(record, Schema):
                        schemas[record.id] = record.name
                    elif isinstance(record, Channel):
                        qos = yaml.safe_load(record.metadata.get("offered_qos_profiles", "") or "[]") or []
                        type_name = _type_name(schemas[record.schema_id])
                        channels[record.id] = TopicRecord(record.topic, type_name, qos, record.id)
                        contents.topics.setdefault(record.topic, TopicRecord(record.topic, type_name, qos, record.id))
                    elif isinstance(record, Message):
                        channel = channels[record.channel_id]
                        contents._count(channel.name, record.log_time)
                        if topics is None or channel.name in topics:
                            yield RawMessage(channel.name, channel.type_name, record.data, record.log_time,
                                             record.publish_time)
                    elif isinstance(record, Footer):
                        complete = True
            except (McapError, EOFError, KeyError, ValueError, OSError) as exc:
                contents.error = f"{path.name}: " + (f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__)
                contents.complete = False
                return
        if not complete:
            contents.error = f"{path.name} ends before the MCAP footer (truncated)"
            contents.complete = False
            return


def _stream_rosbags(contents: BagContents, topics: set[str] | None) -> Iterator[RawMessage]:
    """Messages of a bag that rosbags reads (sqlite3), in log-time order."""
    from .any_reader import AnyBagError, open_bag

    try:
        with open_bag(contents.directory) as reader:
            for c in reader.connections:
                qos = _rosbags_qos(c)
                contents.topics.setdefault(c.topic, TopicRecord(c.topic, c.msgtype, qos, c.id))
            wanted = [c for c in reader.connections if topics is None or c.topic in topics]
            others = [c for c in reader.connections if c not in wanted]
            for c in others:   # counted from the index, not read
                record = contents.topics[c.topic]
                record.count += int(c.msgcount)
            if others:
                contents.start_ns = reader.start_time
                contents.end_ns = reader.end_time - 1 if reader.end_time > reader.start_time else reader.end_time
            if wanted:
                for conn, log_ns, data in reader.messages(connections=wanted):
                    contents._count(conn.topic, log_ns)
                    yield RawMessage(conn.topic, conn.msgtype, bytes(data), log_ns, log_ns)
        contents.complete = True
    except AnyBagError as exc:
        contents.error = str(exc)
    except Exception as exc:  # noqa: BLE001 - sqlite3/rosbags errors part-way: report, keep what was read
        contents.error = f"{type(exc).__name__}: {exc}"


def _rosbags_qos(connection) -> list[dict]:
    """``offered_qos_profiles`` of a rosbags connection as rosbag2 v9 dicts (names lower-case)."""
    ext = getattr(connection, "ext", None)
    profiles = getattr(ext, "offered_qos_profiles", None) or []
    if isinstance(profiles, str):
        return yaml.safe_load(profiles) or []
    out = []
    for q in profiles:
        entry = {}
        for key in ("history", "depth", "reliability", "durability"):
            value = getattr(q, key, None)
            entry[key] = value.name.lower() if hasattr(value, "name") else value
        out.append(entry)
    return out


def stream(directory: Path, topics: set[str] | None = None) -> Iterator[RawMessage | BagContents]:
    """Yield every readable message (MCAP: in file order; sqlite3: in log-time order), then
    the :class:`BagContents` summary. ``topics``: only these (None: all; counts cover all)."""
    found = locate(directory)
    contents = BagContents(found.directory, found.files[0], found.has_metadata, storage=found.storage,
                           files=list(found.files), metadata_required=found.metadata_required)
    if found.storage == "mcap":
        yield from _stream_mcap(contents, topics)
    else:
        yield from _stream_rosbags(contents, topics)
    yield contents


def scan(directory: Path) -> BagContents:
    """Counts, span and state of a bag without keeping its messages."""
    for item in stream(directory, topics=set()):
        if isinstance(item, BagContents):
            return item
    raise AssertionError("stream always ends with its summary")


def require_messages(directory: Path) -> None:
    """Raise :class:`BagError` unless a first message of the bag can be read (reads no further)."""
    items = stream(directory)
    try:
        first = next(items)
    finally:
        items.close()
    if isinstance(first, BagContents):
        raise BagError(f"{directory}: no message can be read from this bag"
                       + (f" ({first.error})" if first.error else " (it holds none)"))


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
    if locate(directory).storage != "mcap":
        raise BagError(f"{directory}: a sqlite3 bag has no chunks to recover: sqlite commits every message, "
                       f"and a killed recording only lacks metadata.yaml, which `ros2 bag reindex` rebuilds")
    messages, contents = read_messages(directory)
    if not messages:
        raise BagError(f"{directory}: nothing to recover: " + (f"no complete chunk can be read ({contents.error})"
                                                               if contents.error else "the bag holds no messages"))
    writer = BagWriter(output)
    for topic in contents.topics.values():
        writer.add_topic(topic.name, topic.type_name, topic.qos_profiles)
    for msg in messages:
        writer.write(msg.topic, msg.data, msg.log_time_ns, msg.publish_time_ns)
    writer.close()
    return output, contents
