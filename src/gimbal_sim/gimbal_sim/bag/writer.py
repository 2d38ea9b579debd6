"""rosbag2-compatible bag writer: ``<dir>/metadata.yaml`` + ``<dir>/<name>_0.mcap``.

MCAP profile ``ros2``: ``ros2msg`` schemas (full definitions with dependencies), ``cdr``
message encoding, ``offered_qos_profiles`` in the channel metadata, log and publish times
in ns. Messages are written raw, as they came off the wire. Chunks are zstd-compressed by
default (``compress=False``: stored as they are); compression is inside the MCAP, per chunk,
so ``metadata.yaml`` names no rosbag2 compression and every MCAP reader (the ``mcap``
library, ``rosbags``, ``ros2 bag``, Foxglove) decompresses it itself.

Crash safety: the current chunk is finished, written and fsync'd whenever the log time
has advanced ``chunk_duration_ns`` past the last flush, or one wall second has passed, so
a SIGKILL or a power cut loses at most that much. A writer far faster than real time (the
engine's bag: ``sync_wall_s``) fsyncs its chunks at most once a wall second: a SIGKILL
still loses at most ``chunk_duration_ns`` of log time, a power cut that wall second. ``metadata.yaml`` is written by
:meth:`close`; a bag without it (or whose MCAP has no footer) was not closed cleanly.
Chunks are compressed and written by :mod:`.chunk_spool`, the same bytes as the mcap
library's; with ``background`` (the engine's bag) on a thread of its own while the caller
goes on: a SIGKILL then loses, besides, the chunks handed to that thread and not yet
written: at most those of the last :meth:`write_records` call (the engine's block before
the one it steps), or :data:`.chunk_spool.MAX_IN_FLIGHT` chunks message by message.

A full or failing disk (:mod:`.disk`) stops the bag in order: the file is cut back to the
last chunk boundary on disk, the reserve kept beside the bag is freed, and the bag is
closed from there (summary, footer, ``metadata.yaml`` with ``custom_data.stopped``); the
write raises :class:`DiskStopped` saying so, with the device and its free space.
"""
from __future__ import annotations

import os
import struct
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
import numpy as np
from mcap.opcode import Opcode
from mcap.writer import CompressionType, Writer

from .chunk_spool import ChunkFinisher, ChunkSpool
from .disk import disk_error_line, free_reserve, is_disk_error, take_reserve
from .qos_yaml import qos_yaml
from .schemas import ros2msg_schema

#: libyaml's emitter when PyYAML has it (the same text, ten times faster)
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
METADATA_VERSION = 9
ROS_DISTRO = "jazzy"
LIBRARY = "gimbal_sim bag writer (mcap python)"


class DiskStopped(RuntimeError):
    """The disk filled up (or failed) under the bag: it was closed at its last chunk on disk."""


class _DiskFile:
    """The MCAP's file, unbuffered: each write reaches the OS at once, so a full disk fails
    the write that fills it, and the file can be cut back to a chunk boundary."""

    def __init__(self, path: Path) -> None:
        self.fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self.pos = 0

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            n = os.write(self.fd, view)
            view, self.pos = view[n:], self.pos + n
        return len(data)

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        pass

    def sync(self) -> None:
        os.fsync(self.fd)

    def cut(self, offset: int) -> None:
        os.ftruncate(self.fd, offset)
        os.lseek(self.fd, offset, os.SEEK_SET)
        self.pos = offset

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


@dataclass
class TopicRecord:
    name: str
    type_name: str
    qos_profiles: list[dict[str, Any]]
    channel_id: int
    count: int = 0


#: An MCAP Message record's head: opcode 0x05, record length, channel id, sequence, log and
#: publish time (the MCAP specification's layout).
_MESSAGE = struct.Struct("<BQHIQQ")
_MESSAGE_OPCODE = 0x05
_INDEX_HEAD = struct.Struct("<BQHI")


class _BlockEntries:
    """The MessageIndex entries of the blocks a chunk holds (:meth:`_Appender.add_block`),
    split by channel once, when the chunk's indexes are written."""

    def __init__(self, chunk: int) -> None:
        self.chunk = chunk  # the chunks finished before this one
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._split: dict[int, np.ndarray] | None = None

    def of(self, channel_id: int) -> np.ndarray:
        if self._split is None:
            channels, logs, offsets = (np.concatenate(a) for a in zip(*self.parts))
            order = np.argsort(channels, kind="stable")
            ids, first = np.unique(channels[order], return_index=True)
            entries = np.stack([logs[order], offsets[order]], axis=1).astype("<u8")
            self._split = dict(zip(ids.tolist(), np.split(entries, first[1:])))
        return self._split.get(channel_id, np.empty((0, 2), dtype="<u8"))


class _ChannelIndex:
    """A channel's MessageIndex in a chunk (the mcap library's ``MessageIndex``, whose
    ``write`` packs each entry in two calls), its entries those :meth:`_Appender.add` made
    and those of the chunk's blocks (:class:`_BlockEntries`), written in one call."""

    def __init__(self, channel_id: int) -> None:
        self.channel_id = channel_id
        self.records: list[tuple[int, int]] = []
        self.blocks: _BlockEntries | None = None

    def write(self, stream) -> None:
        entries = np.asarray(self.records, dtype="<u8").reshape(-1, 2)
        if self.blocks is not None:
            entries = np.concatenate([entries, self.blocks.of(self.channel_id)])
            if self.records:  # both kinds: in the order they are in the chunk
                entries = entries[np.argsort(entries[:, 1], kind="stable")]
        data = entries.tobytes()
        stream.write(_INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, 6 + len(data), self.channel_id, len(data)))
        stream.write(data)


class _Appender:
    """The mcap writer's ``add_message`` in one ``struct`` call per message (the library's own
    builds a record object and writes it in six calls: most of what recording costs the
    engine). It keeps the writer's statistics, the chunk's message index and time range, and
    finishes a chunk when it is full, as ``add_message`` does, through the writer's state as
    mcap 1.6 holds it; :meth:`available` is False for another layout, and the writer then
    uses ``add_message`` itself."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.stats = writer._Writer__statistics  # noqa: SLF001 - see the class docstring
        self.chunk = writer._Writer__chunk_builder  # noqa: SLF001
        self.chunk_size = writer._Writer__chunk_size  # noqa: SLF001
        self.finish_chunk = writer._Writer__maybe_finalize_chunk  # noqa: SLF001
        self._blocks: _BlockEntries | None = None

    @staticmethod
    def available(writer: Writer) -> bool:
        names = ("_Writer__statistics", "_Writer__chunk_builder", "_Writer__chunk_size", "_Writer__maybe_finalize_chunk")
        chunk = getattr(writer, "_Writer__chunk_builder", None)
        return all(hasattr(writer, n) for n in names) and chunk is not None and \
            all(hasattr(chunk, n) for n in ("message_indices", "record_writer", "num_messages", "message_start_time",
                                            "message_end_time")) and hasattr(chunk.record_writer, "_buffer")

    def add(self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int) -> None:
        stats, chunk = self.stats, self.chunk
        if stats.message_count == 0 or log_time < stats.message_start_time:
            stats.message_start_time = log_time
        if log_time > stats.message_end_time:
            stats.message_end_time = log_time
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1
        if chunk.num_messages == 0 or log_time < chunk.message_start_time:
            chunk.message_start_time = log_time
        if log_time > chunk.message_end_time:
            chunk.message_end_time = log_time
        buf = chunk.record_writer._buffer  # noqa: SLF001
        self._index(channel_id).records.append((log_time, buf.tell()))
        chunk.num_messages += 1
        buf.write(_MESSAGE.pack(_MESSAGE_OPCODE, 22 + len(data), channel_id, sequence, log_time, publish_time))
        buf.write(data)
        if buf.tell() > self.chunk_size:
            self.finish_chunk()

    def _index(self, channel_id: int) -> _ChannelIndex:
        index = self.chunk.message_indices.get(channel_id)
        if index is None:
            index = self.chunk.message_indices[channel_id] = _ChannelIndex(channel_id)
        return index

    @property
    def position(self) -> int:
        """Bytes in the chunk in progress."""
        return self.chunk.record_writer._buffer.tell()  # noqa: SLF001

    def add_block(self, data: np.ndarray, starts: np.ndarray, log_times: np.ndarray, channels: np.ndarray,
                  counts: dict[int, int]) -> None:
        """:meth:`add` for Message records already laid out back to back in ``data`` (each
        starting at ``starts[i] - starts[0]``), in log-time order, ``counts`` of them on each
        channel; the caller finishes the chunk."""
        stats, chunk = self.stats, self.chunk
        lo, hi = int(log_times[0]), int(log_times[-1])
        if stats.message_count == 0 or lo < stats.message_start_time:
            stats.message_start_time = lo
        stats.message_end_time = max(stats.message_end_time, hi)
        if chunk.num_messages == 0 or lo < chunk.message_start_time:
            chunk.message_start_time = lo
        chunk.message_end_time = max(chunk.message_end_time, hi)
        buf = chunk.record_writer._buffer  # noqa: SLF001
        blocks = self._blocks
        if blocks is None or blocks.chunk != stats.chunk_count:
            blocks = self._blocks = _BlockEntries(stats.chunk_count)
        # copies: the chunk writer's thread reads them after the caller has gone on
        blocks.parts.append((channels.copy(), log_times.copy(), starts - starts[0] + buf.tell()))
        for channel_id, count in counts.items():
            self._index(channel_id).blocks = blocks
            stats.channel_message_counts[channel_id] += count
        stats.message_count += len(starts)
        chunk.num_messages += len(starts)
        buf.write(data)


@dataclass
class BagWriter:
    """Write one bag directory; :meth:`close` finishes the MCAP and writes metadata."""

    directory: Path
    name: str | None = None
    chunk_duration_ns: int = 500_000_000
    #: zstd-compress each chunk (level 3, the mcap library's): about 5x smaller for our topics
    compress: bool = True
    wall_flush_s: float = 1.0
    #: fsync a finished chunk only when this many wall seconds have passed since the last
    #: fsync (None: every chunk). For a writer far faster than real time (the engine), whose
    #: chunks, written at the log-time rule, survive a SIGKILL without it
    sync_wall_s: float | None = None
    #: compress and write finished chunks on a thread of its own (:mod:`.chunk_spool`), so
    #: that the caller goes on meanwhile; :meth:`close` ends the thread
    background: bool = False
    topics: dict[str, TopicRecord] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.directory = Path(self.directory)
        existing = [p.name for p in self.directory.glob("*") if p.name == "metadata.yaml" or p.suffix == ".mcap"]
        if existing:
            raise FileExistsError(f"{self.directory} already holds a bag ({', '.join(existing)}); not overwriting it")
        self.directory.mkdir(parents=True, exist_ok=True)
        self.name = self.name or self.directory.name
        self.mcap_path = self.directory / f"{self.name}_0.mcap"
        self._reserve = take_reserve(self.directory)
        self._file = _DiskFile(self.mcap_path)
        self._spool = ChunkSpool(self._file, self.background)
        self._writer = Writer(self._spool, chunk_size=1 << 24,
                              compression=CompressionType.ZSTD if self.compress else CompressionType.NONE)
        ChunkFinisher.install(self._writer, self._spool)
        self._good: tuple = (0, {}, None, 0)
        self._schemas: dict[str, int] = {}
        self._qos_text: dict[str, str] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self._last_flush_ns = 0
        self._last_flush_wall = self._last_sync_wall = time.monotonic()
        self.closed = False
        #: why the bag stopped before it was closed (a full disk), else None
        self.stopped: str | None = None
        self._on_disk(lambda: self._writer.start(profile="ros2", library=LIBRARY))
        self._appender = _Appender(self._writer) if _Appender.available(self._writer) else None
        self._add = self._appender.add if self._appender is not None else self._add_message
        self._mark_on_disk()

    def add_topic(self, topic: str, type_name: str, qos_profiles: list[dict[str, Any]]) -> None:
        """Register a topic before writing its messages (idempotent)."""
        if topic in self.topics:
            return
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            pkg, _, name = type_name.split("/")
            schema_id = self._on_disk(lambda: self._writer.register_schema(
                name=f"{pkg}/msg/{name}", encoding="ros2msg", data=ros2msg_schema(type_name).encode()))
            self._schemas[type_name] = schema_id
        key = repr(qos_profiles)  # most topics offer the same profiles
        if key not in self._qos_text:
            self._qos_text[key] = qos_yaml(qos_profiles)
        channel_id = self._on_disk(lambda: self._writer.register_channel(
            topic=topic, message_encoding="cdr", schema_id=schema_id,
            metadata={"offered_qos_profiles": self._qos_text[key]}))
        self.topics[topic] = TopicRecord(topic, type_name, qos_profiles, channel_id)

    def _add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int) -> None:
        self._writer.add_message(channel_id=channel_id, log_time=log_time, data=data, publish_time=publish_time,
                                 sequence=sequence)

    def write(self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        record = self.topics[topic]
        if self.closed:
            self._on_disk(lambda: None)  # raises DiskStopped
        try:  # inline, not through _on_disk: the recorder's per-message path
            self._add(record.channel_id, log_time_ns, data, log_time_ns if publish_time_ns is None else publish_time_ns,
                      record.count)
        except OSError as exc:
            self._stop_on(exc)
        record.count += 1
        self._reach(log_time_ns, log_time_ns)

    def sequence(self, topic: str) -> int:
        """The sequence number the next message of ``topic`` gets (its count so far)."""
        return self.topics[topic].count

    def write_records(self, data: np.ndarray, starts: np.ndarray, log_times: np.ndarray, topics: list[str],
                      topic_of: np.ndarray) -> None:
        """Write many messages at once, as :meth:`write` writes them one by one: ``data`` holds
        their MCAP Message records back to back (uint8), ``starts`` where each begins, in
        log-time order; message i is on ``topics[topic_of[i]]`` (registered) and its sequence number is
        that topic's :meth:`sequence` plus the number of its messages before it. Chunks are
        finished, written and fsync'd where :meth:`write` would finish them; with
        :attr:`background`, compressed and written while the caller goes on, the call
        waiting first for the chunks of the call before."""
        if self.closed:
            self._on_disk(lambda: None)  # raises DiskStopped
        self._on_disk(self._spool.wait)  # the chunks of the call before are on the file (background)
        records = [self.topics.get(t) for t in topics]  # a topic without messages here may be unregistered
        channels = np.array([0 if r is None else r.channel_id for r in records], dtype=np.uint64)[topic_of]
        ends = np.append(starts[1:], len(data))
        i, n = 0, len(starts)
        while i < n:
            k = self._segment_end(starts, ends, log_times, i)
            counts = np.bincount(topic_of[i:k + 1], minlength=len(records)).tolist()
            try:
                if self._appender is None:
                    self._add_each(data, starts, ends, log_times, channels, i, k)
                else:
                    self._appender.add_block(data[starts[i]:ends[k]], starts[i:k + 1], log_times[i:k + 1],
                                             channels[i:k + 1], {records[j].channel_id: c for j, c in
                                                                 enumerate(counts) if c})
                    if self._appender.position > self._appender.chunk_size:
                        self._appender.finish_chunk()
            except OSError as exc:
                self._stop_on(exc)
            for j, count in enumerate(counts):
                if count:
                    records[j].count += count
            self._reach(int(log_times[i]), int(log_times[k]))
            i = k + 1

    def _reach(self, lo: int, hi: int) -> None:
        """Messages logged from ``lo`` to ``hi`` [ns] are in: the bag's span grows to them, and
        the chunk goes to disk once it spans ``chunk_duration_ns`` or waited ``wall_flush_s``."""
        if self._start_ns is None or lo < self._start_ns:
            self._start_ns = lo
        self._end_ns = max(self._end_ns, hi)
        if hi - self._last_flush_ns >= self.chunk_duration_ns or \
                time.monotonic() - self._last_flush_wall >= self.wall_flush_s:
            self.flush()

    def _segment_end(self, starts: np.ndarray, ends: np.ndarray, log_times: np.ndarray, i: int) -> int:
        """The last message from ``i`` on after which :meth:`write` would finish a chunk: the
        log time ``chunk_duration_ns`` past the last flush, or the chunk over its size."""
        k = int(np.searchsorted(log_times, self._last_flush_ns + self.chunk_duration_ns, side="left"))
        if self._appender is not None:
            room = self._appender.chunk_size - self._appender.position
            k = min(k, int(np.searchsorted(ends, starts[i] + room, side="right")))
        return min(max(k, i), len(starts) - 1)

    def _add_each(self, data, starts, ends, log_times, channels, i: int, k: int) -> None:
        """The mcap library's ``add_message`` for each record i … k (another mcap layout)."""
        for j in range(i, k + 1):
            head = _MESSAGE.unpack_from(data, int(starts[j]))
            self._add(int(channels[j]), int(log_times[j]), bytes(data[starts[j] + _MESSAGE.size:ends[j]]), head[5],
                      head[3])

    def flush(self) -> None:
        """Finish the chunk in progress, write it and fsync it (see :attr:`sync_wall_s`): a
        chunk boundary on disk."""
        now = time.monotonic()
        sync = self.sync_wall_s is None or now - self._last_sync_wall >= self.sync_wall_s
        self._on_disk(lambda: (self._writer.flush(), self._spool.then(self._file.sync) if sync else None,
                               self._mark_on_disk()))
        self._last_flush_ns = self._end_ns
        self._last_flush_wall = time.monotonic()
        if sync:
            self._last_sync_wall = self._last_flush_wall

    def _mark_on_disk(self) -> None:
        """What the file holds up to here, all on disk (once the spool has written it): where
        a full disk cuts it back to."""
        mark = ({t: r.count for t, r in self.topics.items()}, self._start_ns, self._end_ns)
        self._spool.then(lambda: setattr(self, "_good", (self._file.tell(), *mark)))

    def _on_disk(self, write):
        """``write()``; a full or failing disk closes the bag at its last chunk on disk and
        raises :class:`DiskStopped`."""
        if self.closed:
            raise DiskStopped(self.stopped or f"the bag {self.directory} is closed")
        try:
            return write()
        except OSError as exc:
            self._stop_on(exc)

    def _stop_on(self, exc: OSError) -> None:
        """A write failed: re-raise it, unless the disk is full or failing; then close the bag
        at its last chunk on disk and raise :class:`DiskStopped`."""
        if not is_disk_error(exc):
            raise exc
        self.stopped = disk_error_line(exc, self.directory)
        try:
            self._close_at_last_chunk()
        except OSError as again:  # not even the reserve's room: the chunks on disk stay readable
            self.stopped += (f"; no room to close the bag ({again.strerror}): its complete chunks are kept, "
                             f"`gimbal-bag recover` reads them")
        raise DiskStopped(self.stopped) from None

    def _close_at_last_chunk(self) -> None:
        """Cut the file back to its last chunk on disk and close the bag from there, in the
        room the reserve gives back. The mcap writer has no call for dropping the chunk it
        was writing: its chunk, index list and statistics are reset here to the file's."""
        self._spool.stop()  # what it was writing is cut off below
        offset, counts, start, end = self._good
        free_reserve(self._reserve)
        self._file.cut(offset)
        for name, record in self.topics.items():
            record.count = counts.get(name, 0)
        self._start_ns, self._end_ns = start, end
        w = self._writer
        w._Writer__chunk_builder.reset()  # noqa: SLF001 - mcap 1.6.0 (pinned)
        w._Writer__record_builder.end()  # noqa: SLF001
        indices = w._Writer__chunk_indices  # noqa: SLF001
        indices[:] = [i for i in indices if i.chunk_start_offset + i.chunk_length + i.message_index_length <= offset]
        stats = w._Writer__statistics  # noqa: SLF001
        stats.chunk_count, stats.message_count = len(indices), self.message_count
        stats.channel_message_counts = defaultdict(int, {r.channel_id: r.count for r in self.topics.values()
                                                         if r.count})
        stats.message_start_time, stats.message_end_time = start or 0, end
        self.closed = True
        try:
            w.finish()
        finally:
            self._file.close()
            write_metadata(self.directory, [self.mcap_path.name], list(self.topics.values()),
                           self._start_ns or 0, self._end_ns, stopped=self.stopped)

    @property
    def end_ns(self) -> int:
        """Log time of the newest message written [ns]."""
        return self._end_ns

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def close(self) -> None:
        """Finish the MCAP (summary, footer) and write ``metadata.yaml``."""
        if self.closed:
            return
        try:  # the chunks in flight first, in the room the disk has
            self._on_disk(self._spool.wait)
        finally:
            self._spool.stop()
        free_reserve(self._reserve)  # its room is the summary's
        self._on_disk(lambda: (self._writer.finish(), self._file.sync()))
        self._file.close()
        self.closed = True
        write_metadata(self.directory, [self.mcap_path.name], list(self.topics.values()),
                       self._start_ns or 0, self._end_ns)


def write_metadata(directory: Path, files: list[str], topics: list[TopicRecord], start_ns: int, end_ns: int,
                   stopped: str | None = None) -> None:
    """``metadata.yaml`` in rosbag2 format version 9; ``stopped``: why the recording stopped
    before its end (``custom_data.stopped``)."""
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
        "custom_data": {"stopped": stopped} if stopped else {},
        "ros_distro": ROS_DISTRO,
    }
    text = yaml.dump({"rosbag2_bagfile_information": info}, Dumper=_DUMPER, sort_keys=False,
                     default_flow_style=False)
    tmp = directory / "metadata.yaml.tmp"
    tmp.write_text(text)
    tmp.replace(directory / "metadata.yaml")


def add_custom_data(directory: Path, data: dict[str, str]) -> None:
    """Add ``data`` (text to text, rosbag2's ``custom_data``) to the bag's ``metadata.yaml``."""
    path = Path(directory) / "metadata.yaml"
    doc = yaml.safe_load(path.read_text())
    info = doc["rosbag2_bagfile_information"]
    info["custom_data"] = {**(info.get("custom_data") or {}), **{str(k): str(v) for k, v in data.items()}}
    tmp = path.with_name("metadata.yaml.tmp")
    tmp.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=False))
    tmp.replace(path)
