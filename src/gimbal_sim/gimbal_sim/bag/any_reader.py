"""Stream one topic of any rosbag2 bag as raw CDR, through ``rosbags`` (no message objects).

``rosbags.highlevel.AnyReader`` opens rosbag2 bags of either storage: MCAP (chunk-compressed
or not) and sqlite3 (``.db3``), with or without embedded type definitions (a bag without
them falls back to the ROS 2 Jazzy types). This module adds what a command-line tool needs
on top: a missing path, a directory that is not a bag, a bag that was never closed and a
file cut short all become a :class:`AnyBagError` whose message says which and what to do,
and :func:`iter_raw` yields ``(log time [ns], CDR bytes)`` of one topic in log-time order,
one message at a time, so a caller keeps only what it decodes from them.
"""
from __future__ import annotations

import struct
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag2 import ReaderError
from rosbags.typesys import Stores, get_typestore


class AnyBagError(ValueError):
    """The bag cannot be read (as asked); the message says why."""


@dataclass(frozen=True)
class TopicSummary:
    """One topic of an open bag: name, type (``pkg/msg/Name``), message count."""

    name: str
    msgtype: str
    count: int


def _not_a_bag(path: Path) -> str | None:
    """Why ``path`` is plainly not a rosbag2 bag, or None when it may be one."""
    if not path.exists():
        return f"{path}: no such file or directory"
    if path.is_dir():
        if (path / "metadata.yaml").is_file():
            return None
        storage = sorted(p.name for p in path.iterdir() if p.suffix in (".mcap", ".db3"))
        if storage:
            return (f"{path}: no metadata.yaml beside {', '.join(storage)}: the bag was not closed cleanly "
                    f"(a recording that was killed); `gimbal-bag recover {path}` rewrites every chunk of an MCAP bag "
                    f"that checks into a readable one")
        return f"{path}: not a rosbag2 bag (a directory with metadata.yaml and .mcap or .db3 files)"
    if path.suffix not in (".mcap", ".db3"):
        return f"{path}: not a rosbag2 bag (give the bag directory, or its .mcap / .db3 file)"
    return None


@contextmanager
def open_bag(path: str | Path) -> Iterator[AnyReader]:
    """An open ``AnyReader`` on the rosbag2 bag at ``path`` (directory, or one .mcap/.db3).

    Raises :class:`AnyBagError` for a missing path, something that is not a bag, a bag not
    closed cleanly, or a file rosbags cannot parse (e.g. truncated).
    """
    path = Path(path)
    reason = _not_a_bag(path)
    if reason:
        raise AnyBagError(reason)
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY))
        reader.open()
    except (AnyReaderError, ReaderError, struct.error, EOFError, OSError, KeyError, ValueError) as exc:
        raise AnyBagError(f"{path}: cannot read the bag ({type(exc).__name__}: {exc}); if a recording was "
                          f"cut short, `gimbal-bag recover` rewrites every chunk of an MCAP bag that checks") from exc
    try:
        yield reader
    finally:
        reader.close()


def topics(reader: AnyReader) -> dict[str, TopicSummary]:
    """Every topic of the open bag: name -> :class:`TopicSummary`."""
    return {name: TopicSummary(name, info.msgtype or "?", int(info.msgcount)) for name, info in reader.topics.items()}


def require_topic(reader: AnyReader, topic: str, msgtypes: tuple[str, ...]) -> TopicSummary:
    """The topic's summary; :class:`AnyBagError` when it is missing or of another type than
    one of ``msgtypes`` (``pkg/msg/Name``), listing what the bag has."""
    found = topics(reader)
    if topic not in found:
        listing = ", ".join(f"{t.name} ({t.msgtype})" for t in found.values()) or "none"
        raise AnyBagError(f"topic {topic!r} is not in the bag; its topics: {listing}")
    summary = found[topic]
    if summary.msgtype not in msgtypes:
        raise AnyBagError(f"topic {topic!r} is {summary.msgtype}, expected {' or '.join(msgtypes)}")
    return summary


def iter_raw(reader: AnyReader, topic: str) -> Iterator[tuple[int, bytes]]:
    """``(log time [ns], raw CDR bytes)`` of every message on ``topic``, in log-time order.

    A read error part-way (a corrupt or truncated chunk) raises :class:`AnyBagError` saying
    how many messages were read before it.
    """
    connections = [c for c in reader.connections if c.topic == topic]
    if not connections:
        raise AnyBagError(f"topic {topic!r} is not in the bag")
    count = 0
    try:
        for _, log_ns, data in reader.messages(connections=connections):
            count += 1
            yield log_ns, data
    except (AnyReaderError, ReaderError, struct.error, EOFError, OSError, KeyError, ValueError) as exc:
        raise AnyBagError(f"the bag is corrupt or truncated after {count} messages of {topic!r} "
                          f"({type(exc).__name__}: {exc})") from exc
