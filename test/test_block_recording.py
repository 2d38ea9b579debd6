"""Recording a block of engine steps at once gives the bag that recording them one by one
gives: the byte templates derived from the nodes' serialisation functions reproduce those
functions' bytes for random rows (every message of paper 1's chain); a recorded run, with a
``record`` list and a record rate, equals byte for byte (topics, sequence numbers, log times,
payloads, file order) the run recorded message by message through the same functions; every
MessageIndex entry, read with the ``mcap`` library's stream reader, points at its message;
``rosbags`` reads the bag; :meth:`BagWriter.write_records` finishes chunks where
:meth:`BagWriter.write` does and closes the bag at its last chunk on disk when the disk fills.
"""
from __future__ import annotations

import dataclasses
import errno
import os
import struct
from pathlib import Path

import numpy as np
import pytest
import zstandard
from mcap.reader import make_reader
from mcap.records import Chunk, MessageIndex
from mcap.stream_reader import StreamReader
from rosbags.highlevel import AnyReader

from gimbal_kinematics.ros.wire import clock_cdr, navsat_fix_cdr
from gimbal_sim.bag import writer
from gimbal_sim.bag.record_rates import RecordRates
from gimbal_sim.core import block_bag, compiled_sighting
from gimbal_sim.core.core_loop import node_values
from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.graph.scenario import load, variant

#: the MCAP specification's Message record head: opcode, length, channel, sequence, log, publish time
MESSAGE = struct.Struct("<BQHIQQ")


def _scenario(seconds: float = 1.0):
    s = variant(load("sighting_land_vehicle"), "ekf_on")
    return dataclasses.replace(s, duration_s=seconds)


def _publisher(tmp_path: Path) -> compiled_sighting._Publisher:
    from gimbal_sim.core.recording import EngineBag

    values = node_values(_scenario())
    vehicle, suite, *_ = compiled_sighting._cores(values)
    bag = EngineBag(tmp_path / "bag", _scenario())
    return compiled_sighting._Publisher(values, vehicle, suite, bag)


def test_templates_give_the_serialisation_functions_bytes_for_random_rows(tmp_path):
    sources = _publisher(tmp_path).sources
    rng = np.random.default_rng(7)
    rows = rng.normal(size=(40, compiled_sighting.sk.N_REC)) * 10.0 ** rng.integers(-9, 9, (40, 1))
    stamps = np.sort(rng.integers(0, 10**13, 40))
    types = set()
    for s in sources:
        assert all(t is not None for t in s.templates), s.messages  # all of this chain in bulk
        index = np.arange(len(rows))
        column = s.columns(rows, index)
        for i, (_, type_name) in enumerate(s.messages):
            raw = np.empty((len(rows), s.sizes[i]), dtype=np.uint8)
            s.payloads(i, stamps, rows, index, column, raw)
            for k in range(len(rows)):
                assert raw[k].tobytes() == s.fn(int(stamps[k]), rows[k])[i][2], (s.messages[i], k)
            types.add(type_name)
    assert len(types) == 5  # Imu, JointState, Vector3Stamped, NavSatFix, Clock


def test_a_value_the_function_transforms_is_serialised_by_the_function():
    # the fix's latitude and longitude are written in degrees: no column holds them
    fn = lambda t, r: [("/fix", "sensor_msgs/msg/NavSatFix", navsat_fix_cdr(t, "map", r[0], r[1], r[2]))]  # noqa: E731
    source = block_bag.BlockSource("n", fn, 3)
    assert source.templates == [None]
    rows, stamps = np.array([[0.1, 0.2, 3.0], [0.4, -0.5, 6.0]]), np.array([10**9, 2 * 10**9 + 5])
    raw = np.empty((2, source.sizes[0]), dtype=np.uint8)
    source.payloads(0, stamps, rows, np.arange(2), source.columns(rows, np.arange(2)), raw)
    assert [raw[k].tobytes() for k in range(2)] == [fn(int(stamps[k]), rows[k])[0][2] for k in range(2)]


def _scalar_call(self, stamps, rows, masks):
    """The reference: each step's messages through EngineBag one call at a time, in order."""
    for k in range(len(stamps)):
        for s, m in zip(self.sources, masks):
            if m is None or m[k]:
                self.bag(s.node, s.fn(int(stamps[k]), rows[k]))


def _messages(bag: Path) -> list[tuple]:
    with open(next(bag.glob("*.mcap")), "rb") as f:
        return [(c.topic, m.sequence, m.log_time, m.publish_time, m.data)
                for _, c, m in make_reader(f).iter_messages(log_time_order=False)]


def _check_index(bag: Path) -> int:
    """Every MessageIndex entry points at a Message record of its channel and log time."""
    checked, chunk = 0, b""
    with open(next(bag.glob("*.mcap")), "rb") as f:
        for rec in StreamReader(f, skip_magic=False, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                chunk = zstandard.ZstdDecompressor().decompress(rec.data, max_output_size=rec.uncompressed_size)
            elif isinstance(rec, MessageIndex):
                for log_time, offset in rec.records:
                    op, _, channel, _, t, _ = MESSAGE.unpack_from(chunk, offset)
                    assert (op, channel, t) == (0x05, rec.channel_id, log_time)
                    checked += 1
    return checked


def test_a_run_recorded_in_blocks_equals_it_recorded_message_by_message(tmp_path, monkeypatch):
    topics = ["/truth/host/imu", "/gimbal/imu", "/ins/imu", "/gyro_bias_ekf/attitude", "/gimbal/torque_cmd",
              "/truth/ins/gyro_bias", "/clock"]
    scenario = dataclasses.replace(_scenario(9.0), record=topics,
                                   record_rates_hz={"/truth/host/imu": 40.0, "/ins/imu": 7.0})
    run_engine(scenario, tmp_path / "block")
    monkeypatch.setattr(block_bag.BlockRecorder, "__call__", _scalar_call)
    run_engine(scenario, tmp_path / "scalar")
    block, scalar = _messages(tmp_path / "block"), _messages(tmp_path / "scalar")
    assert block == scalar
    assert {t for t, *_ in block} == set(topics)
    assert sum(t == "/truth/host/imu" for t, *_ in block) == 9 * 40 + 1  # every 25 ms
    assert _check_index(tmp_path / "block") == len(block)
    with AnyReader([tmp_path / "block"]) as reader:
        assert sum(1 for c, _, raw in reader.messages() if reader.deserialize(raw, c.msgtype)) == len(block)


def test_record_rates_keep_the_same_messages_in_bulk():
    rng = np.random.default_rng(3)
    stamps = np.sort(rng.integers(0, 5 * 10**9, 3000))
    one, bulk = RecordRates({"/a": 13.0}), RecordRates({"/a": 13.0})
    want = [one.keep("/a", int(t)) for t in stamps]
    got = np.concatenate([bulk.keep_sorted("/a", part) for part in np.array_split(stamps, 7)])
    assert got.tolist() == want and bulk.dropped == one.dropped


def _records(n: int, t0: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n /clock messages every 1 ms as MCAP Message records back to back (sequence from 0)."""
    data = b"".join(MESSAGE.pack(0x05, 22 + 12, 1, k, t0 + k * 10**6, t0 + k * 10**6) + clock_cdr(t0 + k * 10**6)
                    for k in range(n))
    return (np.frombuffer(bytearray(data), dtype=np.uint8), np.arange(n, dtype=np.int64) * (31 + 12),
            t0 + np.arange(n, dtype=np.int64) * 10**6)


def test_write_records_finishes_chunks_where_write_does(tmp_path):
    one = writer.BagWriter(tmp_path / "one", chunk_duration_ns=100_000_000, wall_flush_s=1e9)
    bulk = writer.BagWriter(tmp_path / "bulk", chunk_duration_ns=100_000_000, wall_flush_s=1e9)
    for w in (one, bulk):
        w.add_topic("/clock", "rosgraph_msgs/msg/Clock", [])
    data, starts, log = _records(1234)
    for k in range(len(log)):
        one.write("/clock", data[starts[k] + 31:starts[k] + 43].tobytes(), int(log[k]))
    for part in np.array_split(np.arange(len(log)), 5):  # blocks cut across chunks
        lo, hi = part[0], part[-1]
        end = starts[hi] + 43
        bulk.write_records(data[starts[lo]:end], starts[lo:hi + 1] - starts[lo], log[lo:hi + 1], ["/clock"],
                           np.zeros(len(part), dtype=np.int64))
    one.close()
    bulk.close()

    def chunks(bag):
        with open(next(bag.glob("*.mcap")), "rb") as f:
            return [(c.message_start_time, c.message_end_time) for c in make_reader(f).get_summary().chunk_indexes]
    assert chunks(tmp_path / "bulk") == chunks(tmp_path / "one") and len(chunks(tmp_path / "one")) == 13
    assert _messages(tmp_path / "bulk") == _messages(tmp_path / "one")
    assert _check_index(tmp_path / "bulk") == _check_index(tmp_path / "one") == 1234


@pytest.mark.parametrize("where", ["write", "sync"])
def test_write_records_closes_the_bag_at_its_last_chunk_on_disk(where, tmp_path, monkeypatch):
    bag = writer.BagWriter(tmp_path / "bag", chunk_duration_ns=100_000_000, wall_flush_s=1e9)
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock", [])
    real_write, real_sync = writer._DiskFile.write, writer._DiskFile.sync
    flushes, failed = [], []

    def fails():  # the fourth chunk fails once; the freed reserve's room closes the bag
        if len(flushes) >= 3 and not failed:
            failed.append(1)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def write(self, data):
        if where == "write":
            fails()
        return real_write(self, data)

    def sync(self):
        if where == "sync":
            fails()
        real_sync(self)
        flushes.append(bag.message_count)

    monkeypatch.setattr(writer._DiskFile, "write", write)
    monkeypatch.setattr(writer._DiskFile, "sync", sync)
    data, starts, log = _records(2000)
    with pytest.raises(writer.DiskStopped) as stop:
        bag.write_records(data, starts, log, ["/clock"], np.zeros(len(log), dtype=np.int64))
    assert str(stop.value).startswith("disk full") and bag.closed
    monkeypatch.undo()
    kept = _messages(tmp_path / "bag")
    assert len(kept) == flushes[-1] == 301  # three chunks: to 100, 200, 300 ms
    assert [m[1] for m in kept] == list(range(301))
    assert not (tmp_path / "bag" / ".space_reserve").exists()


def test_the_engine_bag_fsyncs_once_a_wall_second(tmp_path, monkeypatch):
    synced = []
    real_sync = writer._DiskFile.sync
    monkeypatch.setattr(writer._DiskFile, "sync", lambda self: (synced.append(1), real_sync(self)))
    bag = writer.BagWriter(tmp_path / "bag", chunk_duration_ns=100_000_000, sync_wall_s=3600.0)
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock", [])
    data, starts, log = _records(1000)
    bag.write_records(data, starts, log, ["/clock"], np.zeros(len(log), dtype=np.int64))
    assert synced == [] and bag._good[0] > 0  # chunks written, their boundary marked, no fsync yet
    bag.close()
    assert synced == [1]
