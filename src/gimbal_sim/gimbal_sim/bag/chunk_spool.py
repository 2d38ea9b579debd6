"""An MCAP file's chunks compressed and written off the caller's thread, in file order.

:class:`ChunkSpool` is the mcap ``Writer``'s output stream: every byte the writer hands it
reaches the file in the order handed, at once or (``background``) on a thread of its own.
:class:`ChunkFinisher` takes the writer's chunk finishing (mcap 1.6's ``__finalize_chunk``)
in two halves: the caller takes the chunk's records and message indexes from the writer and
goes on; the spool compresses the records (zstd, at the library's level), computes their
CRC, and writes the Chunk record and its MessageIndex records in one write, then adds the
ChunkIndex the summary needs. The bytes on disk are the library's, byte for byte. zstd,
zlib and ``os.write`` release the GIL, so the engine steps its next block meanwhile.
"""
from __future__ import annotations

import queue
import struct
import threading
import zlib
from typing import Callable

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import ChunkIndex
from mcap.writer import CompressionType, IndexType, Writer

#: A Chunk record's head up to its compression name: opcode, record length, message start and
#: end time, uncompressed size and CRC, the name's length (the MCAP specification's layout)
_CHUNK_HEAD = struct.Struct("<BQQQQII")
_U64 = struct.Struct("<Q")
#: chunks handed to the thread and not yet written, at most (a bound on memory)
MAX_IN_FLIGHT = 8


class ChunkSpool:
    """The MCAP's bytes to ``file``, in the order they are handed over (module docstring).

    With ``background``, the chunks handed over since the caller's last :meth:`wait` (at most
    :data:`MAX_IN_FLIGHT`) are in flight: a SIGKILL loses them besides what writing at once
    loses. A failed write is raised to the caller at its next hand-over, :meth:`wait` or
    :meth:`check`, nothing after it having reached the file."""

    def __init__(self, file, background: bool = False) -> None:
        self.file = file
        self._error: BaseException | None = None
        self._failed = False
        self._jobs: queue.Queue | None = None
        if background:
            self._jobs = queue.Queue()
            self._room = threading.Semaphore(MAX_IN_FLIGHT)
            self._thread = threading.Thread(target=self._run, name="bag-chunk-writer", daemon=True)
            self._thread.start()

    def write(self, data: bytes) -> int:
        """The writer's records outside chunks (header, schemas, summary, footer)."""
        self.then(self.file.write, data)
        return len(data)

    def tell(self) -> int:
        self.wait()
        return self.file.tell()

    def flush(self) -> None:
        """Nothing: each write reaches the file as it is made."""

    def chunk(self, job: Callable[[], None]) -> None:
        """``job()``: a chunk to compress and write, after what was handed over before."""
        self.check()
        if self._jobs is None:
            job()
            return
        self._room.acquire()
        self._jobs.put((job, (), True))

    def then(self, fn: Callable, *args) -> None:
        """``fn(*args)`` after everything handed over before (at once without a thread)."""
        if self._jobs is None:
            fn(*args)
        else:
            self._jobs.put((fn, args, False))

    def wait(self) -> None:
        """Wait until everything handed over is done; raise the error that stopped it."""
        if self._jobs is not None:
            self._jobs.join()
        self.check()

    def check(self) -> None:
        """Raise (once) the error the thread stopped at."""
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def _run(self) -> None:
        while True:
            fn, args, is_chunk = self._jobs.get()
            try:
                if fn is None:
                    return
                if not self._failed:  # after a failure, nothing more reaches the file
                    fn(*args)
            except BaseException as exc:  # noqa: BLE001 - raised in the caller's thread by check()
                self._error, self._failed = exc, True
            finally:
                if is_chunk:
                    self._room.release()
                self._jobs.task_done()

    def stop(self) -> None:
        """Do what was handed over and end the thread; from here on writes happen at once.
        An error the thread stopped at stays for :meth:`check`."""
        if self._jobs is not None:
            self._jobs.put((None, (), False))
            self._thread.join()
            self._jobs = None


class ChunkFinisher:
    """The writer's chunk finishing, its compression and writes on the spool (module
    docstring); installed on the writer by :meth:`install` where the writer's state is laid
    out as mcap 1.6 lays it out (else the library's own finishing stays, on the caller's
    thread, still writing through the spool in order)."""

    _STATE = ("_Writer__chunk_builder", "_Writer__record_builder", "_Writer__statistics", "_Writer__chunk_indices",
              "_Writer__compression", "_Writer__enable_crcs", "_Writer__enable_data_crcs", "_Writer__index_types",
              "_Writer__finalize_chunk")

    def __init__(self, writer: Writer, spool: ChunkSpool) -> None:
        self.builder = writer._Writer__chunk_builder  # noqa: SLF001 - see the class docstring
        self.records = writer._Writer__record_builder  # noqa: SLF001
        self.stats = writer._Writer__statistics  # noqa: SLF001
        self.indices = writer._Writer__chunk_indices  # noqa: SLF001
        self.zstd = writer._Writer__compression == CompressionType.ZSTD  # noqa: SLF001
        self.crcs = writer._Writer__enable_crcs  # noqa: SLF001
        self.message_index = bool(writer._Writer__index_types & IndexType.MESSAGE)  # noqa: SLF001
        self.spool = spool

    @classmethod
    def install(cls, writer: Writer, spool: ChunkSpool) -> bool:
        """Finish ``writer``'s chunks this way; False (nothing changed) for another layout."""
        if not all(hasattr(writer, n) for n in cls._STATE) or writer._Writer__chunk_builder is None or \
                writer._Writer__enable_data_crcs or \
                writer._Writer__compression not in (CompressionType.ZSTD, CompressionType.NONE):  # noqa: SLF001
            return False
        writer._Writer__finalize_chunk = cls(writer, spool)  # noqa: SLF001 - the writer calls it by that name
        return True

    def __call__(self) -> None:
        builder = self.builder
        if builder.num_messages == 0:
            return
        self.stats.chunk_count += 1
        before = self.records.end()  # records the writer holds outside the chunk go first
        if before:
            self.spool.write(before)
        data, start, end = builder.end(), builder.message_start_time, builder.message_end_time
        indexes = list(builder.message_indices.values()) if self.message_index else []
        builder.message_indices = {}  # the spool writes these; the next chunk gets its own
        builder.reset()
        self.spool.chunk(lambda: self._write(data, start, end, indexes))

    def _write(self, data: bytes, start: int, end: int, indexes: list) -> None:
        """The Chunk record and its MessageIndex records, in one write; then its ChunkIndex."""
        packed = zstandard.compress(data) if self.zstd else data
        name = b"zstd" if self.zstd else b""
        head = _CHUNK_HEAD.pack(Opcode.CHUNK, 8 * 3 + 4 + 4 + len(name) + 8 + len(packed), start, end, len(data),
                                zlib.crc32(data) if self.crcs else 0, len(name)) + name + _U64.pack(len(packed))
        at, length = self.spool.file.tell(), len(head) + len(packed)
        index, offsets = RecordBuilder(), {}
        for channel_index in indexes:
            offsets[channel_index.channel_id] = at + length + index.count
            channel_index.write(index)
        tail = index.end()
        self.spool.file.write(b"".join((head, packed, tail)))
        self.indices.append(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=at, chunk_length=length,
            message_index_offsets=offsets, message_index_length=len(tail), compression=name.decode(),
            compressed_size=len(packed), uncompressed_size=len(data)))
