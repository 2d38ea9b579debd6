"""Walk one MCAP file record by record, past damage, keeping every chunk that checks.

The MCAP format frames every record as ``opcode (u8) | length (u64) | body``, so a reader
that loses the thread can find it again: :func:`resync` looks for the next place where an
opcode the spec defines is followed by a length that fits the file, and where the record
after it is framed the same way (or the file ends there with its magic). This is what a
flipped byte in a record header, or bytes that were never written, need.

Each chunk is checked before any of its messages is kept: the chunk record must parse, its
compression (zstd, lz4 or none) must decompress, and the CRC of the uncompressed records
(``uncompressed_crc``; 0 means the writer computed none) must match. A chunk that fails is
reported as :class:`Damage` with its time range, and the MessageIndex records that follow
it (they live outside the chunk) say exactly which channels lost how many messages when.
Schemas and channels are first read from the summary section when the file has one, so a
damaged first chunk (where most writers put the definitions) does not orphan the others.

Record bodies are parsed by the ``mcap`` library's own record classes; this module only
frames records, checks chunks and reports what it could not read.
"""
from __future__ import annotations

import mmap
import re
import struct
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Iterator

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Message, MessageIndex, Schema
from mcap.stream_reader import breakup_chunk

MAGIC = b"\x89MCAP0\r\n"
_HEAD = 9                      # opcode (1) + length (8)
_FOOTER_BODY = 20              # summary start (8), summary offset start (8), summary CRC (4)
_OPCODES = {int(o) for o in Opcode}
#: an opcode byte followed by a little-endian u64 length below 2**32 (a chunk of 4 GiB is
#: beyond any writer's): the only places :func:`resync` looks at
_CANDIDATE = re.compile(rb"(?=[\x01-\x0f].{4}\x00{4})", re.DOTALL)
_INNER = {Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE}
#: the shortest body each record can have (its fixed fields and empty strings, maps and data);
#: DataEnd and Footer have exactly this length
_MIN_BODY = {Opcode.HEADER: 8, Opcode.FOOTER: 20, Opcode.SCHEMA: 14, Opcode.CHANNEL: 16, Opcode.MESSAGE: 22,
             Opcode.CHUNK: 40, Opcode.MESSAGE_INDEX: 6, Opcode.CHUNK_INDEX: 56, Opcode.ATTACHMENT: 36,
             Opcode.ATTACHMENT_INDEX: 48, Opcode.STATISTICS: 38, Opcode.METADATA: 8, Opcode.METADATA_INDEX: 20,
             Opcode.SUMMARY_OFFSET: 17, Opcode.DATA_END: 4}
_EXACT = {Opcode.FOOTER, Opcode.DATA_END}
_READERS = {Opcode.SCHEMA: Schema.read, Opcode.CHANNEL: Channel.read, Opcode.CHUNK: Chunk.read,
            Opcode.MESSAGE_INDEX: MessageIndex.read, Opcode.FOOTER: Footer.read}


@dataclass
class Lost:
    """Messages of one channel that could not be read: how many and when (log time, ns)."""

    count: int
    first_ns: int
    last_ns: int

    def add(self, count: int, first_ns: int, last_ns: int) -> None:
        self.count += count
        self.first_ns, self.last_ns = min(self.first_ns, first_ns), max(self.last_ns, last_ns)


@dataclass
class Damage:
    """One place of a file that could not be read, and what it cost."""

    file: str
    offset: int                    # byte offset of the damaged record (or skipped bytes)
    what: str                      # e.g. "chunk failed its CRC check"
    start_ns: int | None = None    # log-time range the damaged chunk held, when known
    end_ns: int | None = None
    #: channel id -> messages lost, from the chunk's MessageIndex records; empty when the
    #: file does not say (a cut chunk has none after it)
    lost: dict[int, Lost] = field(default_factory=dict)
    summary: bool = False          # in the summary section, after the data: costs no message

    def line(self) -> str:
        span = "" if self.start_ns is None else f", log time {self.start_ns * 1e-9:.3f}..{self.end_ns * 1e-9:.3f} s"
        return f"{self.file}: {self.what} (byte {self.offset}{span})"


@dataclass
class FileWalk:
    """What walking one file found besides its messages."""

    path: Path
    schemas: dict[int, Schema] = field(default_factory=dict)      # defined in the data section
    channels: dict[int, Channel] = field(default_factory=dict)
    #: the summary section's copies, read first: used only for ids the data never defines
    #: (their definition was in a damaged chunk)
    summary_schemas: dict[int, Schema] = field(default_factory=dict)
    summary_channels: dict[int, Channel] = field(default_factory=dict)
    damage: list[Damage] = field(default_factory=list)
    footer: bool = False
    chunks: int = 0                # chunks met (or indexed by the summary), damaged ones included
    orphans: dict[int, Lost] = field(default_factory=dict)   # messages of channels never defined
    compressions: set[str] = field(default_factory=set)      # chunk compressions met ("" = none)
    data_end: int | None = None    # damage entries before the DataEnd record (None: none met)


    def schema(self, schema_id: int) -> Schema | None:
        return self.schemas.get(schema_id) or self.summary_schemas.get(schema_id)

    def channel(self, channel_id: int) -> Channel | None:
        return self.channels.get(channel_id) or self.summary_channels.get(channel_id)


def _u64(data, pos: int) -> int:
    return struct.unpack_from("<Q", data, pos)[0]


def _parse(opcode: int, body: bytes):
    return _READERS[opcode](ReadDataStream(BytesIO(body)))


def _plausible(data, pos: int) -> bool:
    """Whether a record can start at ``pos``: an opcode the spec defines and a length that
    fits the file and the record's fixed fields."""
    if pos + _HEAD > len(data) or data[pos] not in _OPCODES:
        return False
    opcode, length = data[pos], _u64(data, pos + 1)
    if length > len(data) - pos - _HEAD or length < _MIN_BODY[opcode]:
        return False
    return length == _MIN_BODY[opcode] if opcode in _EXACT else True


def _framed(data, pos: int, depth: int) -> bool:
    """Whether ``depth`` records are framed from ``pos`` (the file's end or trailing magic counts)."""
    for _ in range(depth):
        if pos == len(data) or data[pos:pos + 8] == MAGIC:
            return True
        if not _plausible(data, pos):
            return False
        pos += _HEAD + _u64(data, pos + 1)
    return True


def resync(data, start: int, chunked: bool = False, depth: int = 3) -> int | None:
    """The offset of the next record at or after ``start`` that starts a framed run of
    ``depth`` records, or None when none does. In a ``chunked`` file, a Schema, Channel or
    Message record is not a place to resume: those are the records inside an uncompressed
    chunk, and reading them would take a damaged chunk's records without its CRC."""
    for match in _CANDIDATE.finditer(data, start):
        at = match.start()
        if chunked and data[at] in _INNER:
            continue
        if _framed(data, at, depth):
            return at
    return None


def _preload_summary(data, walk: FileWalk) -> None:
    """Schemas and channels of the summary section, when the file ends with a footer."""
    size = len(data)
    footer_at = size - 8 - _HEAD - _FOOTER_BODY
    if footer_at < 8 or data[size - 8:] != MAGIC or data[footer_at] != Opcode.FOOTER:
        return
    pos = _u64(data, footer_at + _HEAD)          # summary start; 0 when there is no summary
    while 8 <= pos < footer_at and pos + _HEAD <= size:
        opcode, length = data[pos], _u64(data, pos + 1)
        if length > footer_at - pos - _HEAD:
            return
        walk.chunks += opcode == Opcode.CHUNK_INDEX   # the file is chunked even when its first chunk is unreadable
        try:
            if opcode == Opcode.SCHEMA:
                record = _parse(opcode, bytes(data[pos + _HEAD:pos + _HEAD + length]))
                walk.summary_schemas[record.id] = record
            elif opcode == Opcode.CHANNEL:
                record = _parse(opcode, bytes(data[pos + _HEAD:pos + _HEAD + length]))
                walk.summary_channels[record.id] = record
        except Exception:  # noqa: BLE001 - a damaged summary only means no head start
            return
        pos += _HEAD + length


def _chunk_records(chunk: Chunk) -> list:
    """The chunk's records once it checks; raises ValueError saying why it does not."""
    if chunk.compression not in ("", "zstd", "lz4"):
        raise ValueError(f"chunk compressed with unknown {chunk.compression!r}")
    try:
        return breakup_chunk(chunk, validate_crc=True)
    except Exception as exc:  # noqa: BLE001 - zstd, lz4, struct and CRC errors alike mean a damaged chunk
        if "crc" in str(exc).lower():
            raise ValueError("chunk failed its CRC check") from None
        if chunk.compression:
            raise ValueError(f"{chunk.compression} chunk does not decompress ({type(exc).__name__})") from None
        raise ValueError(f"chunk records unreadable ({type(exc).__name__})") from None


def _cut(walk: FileWalk, data, pos: int) -> None:
    """The file ends inside the record at ``pos``: report it (a chunk with its time range)."""
    size = len(data)
    opcode = data[pos]
    name = Opcode(opcode).name.title().replace("_", "") if opcode in _OPCODES else f"opcode 0x{opcode:02x}"
    damage = Damage(walk.path.name, pos, f"the file ends inside a {name} record ({size - pos} bytes of it "
                                         f"written): the recording was cut")
    if opcode == Opcode.CHUNK and size - pos >= _HEAD + 16:
        damage.start_ns, damage.end_ns = _u64(data, pos + _HEAD), _u64(data, pos + _HEAD + 8)
    walk.damage.append(damage)


def walk(path: Path, walk_out: FileWalk | None = None) -> Iterator[tuple[Channel, Message]]:
    """Yield ``(channel, message)`` of every readable message of the MCAP file at ``path``,
    in file order; ``walk_out`` (a :class:`FileWalk`) receives definitions and damage."""
    walk_out = walk_out if walk_out is not None else FileWalk(Path(path))
    with open(path, "rb") as f:
        if f.seek(0, 2) == 0:
            walk_out.damage.append(Damage(Path(path).name, 0, "the file is empty"))
            return
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
            yield from _walk(data, walk_out)
    if walk_out.data_end is not None:
        for damage in walk_out.damage[walk_out.data_end:]:
            damage.summary = True
            damage.what += " in the summary section (after every message: none lost)"
    for channel_id, lost in walk_out.orphans.items():
        walk_out.damage.append(Damage(Path(path).name, 0, f"{lost.count} messages of channel {channel_id}, which "
                                      f"no readable Channel record defines", lost.first_ns, lost.last_ns,
                                      {channel_id: lost}))


def _walk(data, w: FileWalk) -> Iterator[tuple[Channel, Message]]:
    size = len(data)
    _preload_summary(data, w)
    pos = 8
    if data[:8] != MAGIC:
        pos = resync(data, 0) or size
        w.damage.append(Damage(w.path.name, 0, "no MCAP magic at the start" +
                               ("" if pos < size else ": not an MCAP file")))
    pending: Damage | None = None  # the damaged chunk whose MessageIndex records follow
    while pos < size:
        opcode = data[pos]
        length = _u64(data, pos + 1) if pos + _HEAD <= size else size
        chunked = w.chunks > 0 or opcode == Opcode.CHUNK
        found = _lost_thread(data, pos, chunked)
        if found is not None:
            if found == size:
                _cut(w, data, pos) if opcode in _OPCODES or pos + _HEAD > size else \
                    w.damage.append(Damage(w.path.name, pos, f"{size - pos} unreadable bytes at the end"))
                return
            w.damage.append(Damage(w.path.name, pos, f"{found - pos} unreadable bytes skipped"))
            pos, pending = found, None
            continue
        body = bytes(data[pos + _HEAD:pos + _HEAD + length])
        if opcode == Opcode.MESSAGE_INDEX and pending is not None:
            _count_lost(pending, body)
        else:
            pending = None
            pending = yield from _record(w, pos, opcode, body)
        pos += _HEAD + length
        if opcode == Opcode.DATA_END:
            w.data_end = len(w.damage)   # what breaks after this is in the summary: no message lost
        if opcode == Opcode.FOOTER:
            w.footer = True
            return


def _consistent(data, pos: int) -> bool:
    """Whether a Chunk's or MessageIndex's own length fields add up to its record length
    (writers add no padding; a length that grew would swallow the records after it)."""
    opcode, length, body = data[pos], _u64(data, pos + 1), pos + _HEAD
    if opcode == Opcode.CHUNK:
        compression = struct.unpack_from("<I", data, body + 28)[0]
        if 32 + compression + 8 > length:
            return False
        return 40 + compression + _u64(data, body + 32 + compression) == length
    if opcode == Opcode.MESSAGE_INDEX:
        return 6 + struct.unpack_from("<I", data, body + 2)[0] == length
    return True


def _lost_thread(data, pos: int, chunked: bool) -> int | None:
    """None when the record at ``pos`` can be believed; else where reading resumes (the
    file's size when nowhere). A record is not believed when it is implausible, when it is a
    Message, Schema or Channel outside the chunks of a chunked file that does not frame the
    records after it, or when the records after it are not framed (or its own length fields
    disagree with its length) and a framed run starts inside it: then its length is what
    was damaged."""
    size = len(data)
    if not _plausible(data, pos) or chunked and data[pos] in _INNER and not _framed(data, pos, 3):
        found = resync(data, pos + 1, chunked=chunked)
        return size if found is None else found
    end = pos + _HEAD + _u64(data, pos + 1)
    if _framed(data, end, 3) and _consistent(data, pos):
        return None
    found = resync(data, pos + 1, chunked=chunked)
    return found if found is not None and found < end else None


def _count_lost(damage: Damage, body: bytes) -> None:
    try:
        index = _parse(Opcode.MESSAGE_INDEX, body)
    except Exception:  # noqa: BLE001 - a damaged index only leaves the loss unknown
        return
    if index.records:
        stamps = [t for t, _ in index.records]
        lost = damage.lost.get(index.channel_id)
        if lost is None:
            damage.lost[index.channel_id] = Lost(len(stamps), min(stamps), max(stamps))
        else:
            lost.add(len(stamps), min(stamps), max(stamps))


def _define(w: FileWalk, pos: int, record: Schema | Channel) -> None:
    """Keep a schema or channel; one that redefines a known id differently is damage (a
    damaged record read as a definition must not retype a channel's messages)."""
    known = w.schemas if isinstance(record, Schema) else w.channels
    if record.id in known and known[record.id] != record:
        w.damage.append(Damage(w.path.name, pos, f"a {type(record).__name__} record redefines id {record.id} "
                                                 f"differently (most likely a damaged record): ignored"))
        return
    known[record.id] = record


def _record(w: FileWalk, pos: int, opcode: int, body: bytes) -> Iterator[tuple[Channel, Message]]:
    """Handle one framed record; returns the :class:`Damage` of a chunk that did not check."""
    if opcode not in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.CHUNK):
        return None
    if opcode == Opcode.MESSAGE and w.chunks:
        # writers that chunk put every message in a chunk; one outside them is covered by no
        # CRC and is most likely another record whose opcode byte was damaged
        w.damage.append(Damage(w.path.name, pos, "a Message record outside the chunks of a chunked file "
                                                 "(no CRC covers it; most likely a damaged record): not read"))
        return None
    try:
        if opcode == Opcode.MESSAGE:
            records = [Message.read(ReadDataStream(BytesIO(body)), len(body))]
        elif opcode == Opcode.CHUNK:
            w.chunks += 1
            chunk = _parse(opcode, body)
            w.compressions.add(chunk.compression)
            try:
                records = _chunk_records(chunk)
            except ValueError as exc:
                damage = Damage(w.path.name, pos, str(exc), chunk.message_start_time, chunk.message_end_time)
                w.damage.append(damage)
                return damage
        else:
            records = [_parse(opcode, body)]
    except Exception as exc:  # noqa: BLE001 - a record whose body does not parse is damage, not a crash
        name = Opcode(opcode).name.title().replace("_", "")
        damage = Damage(w.path.name, pos, f"unreadable {name} record ({type(exc).__name__})")
        w.damage.append(damage)
        return damage if opcode == Opcode.CHUNK else None
    for record in records:
        if isinstance(record, (Schema, Channel)):
            _define(w, pos, record)
        elif isinstance(record, Message):
            channel = w.channel(record.channel_id)
            if channel is None:
                t = record.log_time
                w.orphans.setdefault(record.channel_id, Lost(0, t, t)).add(1, t, t)
                continue
            yield channel, record
    return None
