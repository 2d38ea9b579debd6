"""Read any rosbag2 bag, including truncated or damaged ones, and recover what is left.

Two storages, as rosbag2 writes them:

* MCAP (ours, ``ros2 bag record``'s, ``rosbags``'s, any writer of the ``ros2`` profile;
  chunks uncompressed, zstd or lz4; one file or a split bag's several, in the order
  ``metadata.yaml`` gives). Each file is walked record by record (:mod:`.mcap_walk`) rather
  than through its summary: every chunk is CRC-checked, a damaged chunk or a cut record is
  reported as :class:`~.mcap_walk.Damage` and skipped, and every chunk after it that checks
  is still read. A file cut short by a SIGKILL or a full disk yields every complete chunk.
  A channel without a schema (``schema_id`` 0, which MCAP allows) is typed from
  ``metadata.yaml`` when it names the topic, else that topic alone is refused by name.
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

from .mcap_walk import Damage, FileWalk, Lost, walk
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
    damage: list[Damage] = field(default_factory=list)   # every part of a file that could not be read
    lost: dict[str, Lost] = field(default_factory=dict)  # topic -> messages its damaged chunks held
    unreadable: dict[str, str] = field(default_factory=dict)   # topic -> why none of it can be read
    refused: dict[str, int] = field(default_factory=dict)      # topic -> its messages skipped for that
    spans: dict[str, list[int]] = field(default_factory=dict)  # topic -> [first, last] log time read

    @property
    def closed_cleanly(self) -> bool:
        return self.complete and (self.has_metadata or not self.metadata_required) and self.error is None \
            and not self.damage

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def _count(self, topic: str, t_ns: int) -> None:
        self.topics[topic].count += 1
        span = self.spans.get(topic)
        if span is None:
            self.spans[topic] = [t_ns, t_ns]
        else:
            span[0], span[1] = min(span[0], t_ns), max(span[1], t_ns)
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
    metadata: dict | None = None     # metadata.yaml's rosbag2_bagfile_information, when read


def locate(path: Path, merge: bool = False) -> BagFiles:
    """The storage files of the bag at ``path`` (a bag directory, or one .mcap/.db3 file);
    raises :class:`BagError` saying why it is not a readable bag. Several .mcap files without
    a ``metadata.yaml`` to order them are refused unless ``merge`` (then: in name order)."""
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
        return BagFiles(path, storage, files, True, metadata=info)
    mcaps, db3s = sorted(path.glob("*.mcap")), sorted(path.glob("*.db3"))
    if len(mcaps) > 1 and not db3s and not merge:
        raise BagError(f"{path}: {len(mcaps)} .mcap files ({', '.join(p.name for p in mcaps)}) and no metadata.yaml "
                       f"to say whether they are one split bag or several bags; give one file, or --merge to read "
                       f"them all as one bag in name order")
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


def _metadata_types(found: BagFiles) -> dict[str, str]:
    """topic -> type that ``metadata.yaml`` states (types a channel without a schema)."""
    out = {}
    for entry in (found.metadata or {}).get("topics_with_message_count") or []:
        try:
            out[entry["topic_metadata"]["name"]] = entry["topic_metadata"]["type"]
        except (KeyError, TypeError):
            continue
    return out


def _channel_type(walk_: FileWalk, channel, meta_types: dict[str, str]) -> str | None:
    """``pkg/msg/Name`` of a channel: from its schema, else from the metadata; None when neither says."""
    schema = walk_.schema(channel.schema_id) if channel.schema_id else None
    if schema is not None:
        return _type_name(schema.name)
    return meta_types.get(channel.topic)


def _refuse_channel(contents: BagContents, walk_: FileWalk, channel) -> None:
    why = ("its channel has no schema (schema_id 0) and metadata.yaml names no type for it" if not channel.schema_id
           else f"its schema {channel.schema_id} is in no readable Schema record")
    contents.unreadable.setdefault(channel.topic, f"{walk_.path.name}: {why}; its messages are skipped")


def _stream_mcap(contents: BagContents, topics: set[str] | None, meta_types: dict[str, str]) -> Iterator[RawMessage]:
    """Messages of every MCAP file of the bag in file order; sets ``contents`` as it goes."""
    contents.complete = True
    for path in contents.files:
        file_walk = FileWalk(path)
        known: dict[int, TopicRecord | None] = {}
        for channel, message in walk(path, file_walk):
            record = known.get(channel.id, False)
            if record is False:
                type_name = _channel_type(file_walk, channel, meta_types)
                record = known[channel.id] = None if type_name is None else TopicRecord(
                    channel.topic, type_name, _qos(channel), channel.id)
                if record is None:
                    _refuse_channel(contents, file_walk, channel)
                else:
                    contents.topics.setdefault(channel.topic, TopicRecord(channel.topic, type_name, record.qos_profiles,
                                                                          channel.id))
            if record is None:
                contents.refused[channel.topic] = contents.refused.get(channel.topic, 0) + 1
                continue
            contents._count(channel.topic, message.log_time)
            if topics is None or channel.topic in topics:
                yield RawMessage(channel.topic, record.type_name, message.data, message.log_time,
                                 message.publish_time)
        _account(contents, file_walk)


def _qos(channel) -> list[dict]:
    try:
        return yaml.safe_load(channel.metadata.get("offered_qos_profiles", "") or "[]") or []
    except yaml.YAMLError:
        return []


def _account(contents: BagContents, file_walk: FileWalk) -> None:
    """Fold one file's damage into the bag's: losses per topic, the first problem, completeness."""
    contents.compression |= file_walk.compressions
    for damage in file_walk.damage:
        contents.damage.append(damage)
        for channel_id, lost in damage.lost.items():
            channel = file_walk.channel(channel_id)
            topic = channel.topic if channel is not None else f"(channel {channel_id})"
            if topic in contents.lost:
                contents.lost[topic].add(lost.count, lost.first_ns, lost.last_ns)
            else:
                contents.lost[topic] = Lost(lost.count, lost.first_ns, lost.last_ns)
    if not file_walk.footer:
        contents.complete = False
        if not file_walk.damage:
            file_walk.damage.append(Damage(file_walk.path.name, file_walk.path.stat().st_size,
                                           "the file ends before the MCAP footer (truncated)"))
            contents.damage.append(file_walk.damage[-1])
    if contents.damage and contents.error is None:
        first = contents.damage[0]
        more = len(contents.damage) - 1
        contents.error = first.line() + (f"; and {more} more damaged part{'s' * (more > 1)}" if more else "")


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


def stream(directory: Path, topics: set[str] | None = None, merge: bool = False) -> Iterator[RawMessage | BagContents]:
    """Yield every readable message (MCAP: in file order; sqlite3: in log-time order), then
    the :class:`BagContents` summary. ``topics``: only these (None: all; counts cover all)."""
    found = locate(directory, merge)
    contents = BagContents(found.directory, found.files[0], found.has_metadata, storage=found.storage,
                           files=list(found.files), metadata_required=found.metadata_required)
    if found.storage == "mcap":
        yield from _stream_mcap(contents, topics, _metadata_types(found))
    else:
        yield from _stream_rosbags(contents, topics)
    yield contents


def scan(directory: Path, merge: bool = False) -> BagContents:
    """Counts, span and state of a bag without keeping its messages."""
    for item in stream(directory, topics=set(), merge=merge):
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


def read_messages(directory: Path, topics: set[str] | None = None,
                  merge: bool = False) -> tuple[list[RawMessage], BagContents]:
    messages: list[RawMessage] = []
    for item in stream(directory, topics, merge):
        if isinstance(item, BagContents):
            return messages, item
        messages.append(item)
    raise AssertionError("stream always ends with its summary")


def recover(directory: Path, output: Path | None = None, merge: bool = False) -> tuple[Path, BagContents]:
    """Write every message of a (truncated or damaged) bag's chunks that check to a new, valid bag.

    The new bag goes beside the old one (``<dir>_recovered``) unless ``output`` is given;
    an existing output is refused. Returns the new directory and what was read.
    """
    directory = Path(directory)
    output = Path(output) if output is not None else directory.with_name(directory.name + "_recovered")
    if output.exists():
        raise BagError(f"{output} already exists; not overwriting it")
    if locate(directory, merge).storage != "mcap":
        raise BagError(f"{directory}: a sqlite3 bag has no chunks to recover: sqlite commits every message, "
                       f"and a killed recording only lacks metadata.yaml, which `ros2 bag reindex` rebuilds")
    messages, contents = read_messages(directory, merge=merge)
    if not messages:
        raise BagError(f"{directory}: nothing to recover: " + (f"no chunk that checks can be read ({contents.error})"
                                                               if contents.error else "the bag holds no messages"))
    writer = BagWriter(output)
    for topic in contents.topics.values():
        writer.add_topic(topic.name, topic.type_name, topic.qos_profiles)
    for msg in messages:
        writer.write(msg.topic, msg.data, msg.log_time_ns, msg.publish_time_ns)
    writer.close()
    return output, contents
