"""Every message of every golden bag decodes with the independent readers:
`mcap` + `mcap-ros2-support`, and `rosbags` (bag directory and bare .mcap)."""

from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

ROOT = Path(__file__).resolve().parents[2]
BAGS = sorted(p for p in (ROOT / "bags").iterdir() if (p / "metadata.yaml").is_file())


def test_there_are_golden_bags():
    assert len(BAGS) >= 5


@pytest.mark.parametrize("bag", BAGS, ids=[b.name for b in BAGS])
def test_mcap_ros2_decodes_every_message(bag):
    mcap_file = bag / f"{bag.name}_0.mcap"
    with open(mcap_file, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        for schema in summary.schemas.values():
            assert schema.encoding == "ros2msg"
        for channel in summary.channels.values():
            assert channel.message_encoding == "cdr"
            assert "offered_qos_profiles" in channel.metadata
        count = 0
        topics = set()
        for schema, channel, message, msg in reader.iter_decoded_messages():
            count += 1
            topics.add(channel.topic)
            if channel.topic == "/job":
                assert msg.job_id == bag.name
            if channel.topic == "/toolpath":
                assert sum(len(p.points) for p in msg.passes) == msg.stats.points
        assert count == summary.statistics.message_count
        assert {"/job", "/job_status"} <= topics


@pytest.mark.parametrize("bag", BAGS, ids=[b.name for b in BAGS])
def test_rosbags_decodes_every_message(bag):
    store = get_typestore(Stores.ROS2_JAZZY)
    for path in (bag, bag / f"{bag.name}_0.mcap"):
        with Reader(path) as reader:
            types = {}
            for c in reader.connections:
                types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
            store.register(types)
            count = 0
            for conn, _, raw in reader.messages():
                msg = store.deserialize_cdr(raw, conn.msgtype)
                if conn.topic == "/job_status":
                    assert msg.state in (0, 1, 2, 3, 4)
                count += 1
            assert count == reader.message_count > 0
