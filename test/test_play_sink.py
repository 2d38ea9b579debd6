"""The player hands what it plays to a sink it is given (the live view, ``gimbal-bag play
--live``) and never builds one: each topic under its played (remapped) name and type first,
then every message played, its CDR bytes and log time as the ``rosbags`` writer wrote them, in
the bag's order; the sink is closed with the player. The scene description the live view reads
round-trips through the file a run writes beside its bag."""
from __future__ import annotations

import rclpy
from rclpy.context import Context

from foreign_bags import IMU, JOINT_STATE, synthetic_messages, write_rosbags
from gimbal_kinematics.ros.node_main import make_executor
from gimbal_sim.bag.player import BagPlayer, PlayOptions
from gimbal_sim.bag.scene_config import SCENE_FILE, SceneConfig


class RecordingSink:
    def __init__(self) -> None:
        self.topics: dict[str, str] = {}
        self.messages: list[tuple[str, bytes, int]] = []
        self.closed = 0

    def add_topic(self, topic: str, type_name: str) -> None:
        assert not self.messages, "a topic announced after messages"
        self.topics[topic] = type_name

    def publish(self, topic: str, data: bytes, stamp_ns: int) -> None:
        self.messages.append((topic, bytes(data), stamp_ns))

    def close(self) -> None:
        self.closed += 1


def test_player_hands_every_played_message_to_its_sink(tmp_path):
    written = synthetic_messages(n_imu=30)
    bag = write_rosbags(tmp_path / "bag", written)
    sink = RecordingSink()
    context = Context()
    rclpy.init(context=context)
    executor = None
    try:
        player = BagPlayer(bag, PlayOptions(rate=0.0, remap={"/imu": "/played/imu"}), sink=sink, context=context)
        executor = make_executor(context)
        executor.add_node(player)
        assert player.play(executor) == len(written)
        player.destroy_node()
    finally:
        if executor is not None:
            executor.shutdown()
        rclpy.shutdown(context=context)
    assert sink.topics == {"/played/imu": IMU, "/joints": JOINT_STATE}
    remap = {"/imu": "/played/imu"}
    assert sink.messages == [(remap.get(topic, topic), data, t_ns) for topic, _, t_ns, data in written]
    assert sink.closed == 1


def test_scene_description_round_trips_and_damage_falls_back_to_defaults(tmp_path):
    scene = SceneConfig(target_n=(1500.0, -2500.5, -150.25), platform_heading_rad=0.3, site_lat_rad=0.7,
                        earth_rate=False)
    (tmp_path / SCENE_FILE).write_text(scene.to_json())
    assert SceneConfig.beside(tmp_path) == (scene, None)
    (tmp_path / SCENE_FILE).write_text('{"target_n": null}')
    defaults, why = SceneConfig.beside(tmp_path)
    assert defaults == SceneConfig() and SCENE_FILE in why and "unreadable" in why
