"""Every message of every golden bag, and of a bag recorded by the node itself
(topic jobs and a PlanToolpath goal, whose feedback and goal statuses are
recorded on the action's topics), decodes with the independent readers:
`mcap` + `mcap-ros2-support`, and `rosbags` (bag directory and bare .mcap)."""

import subprocess
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

from harness import action, msgs
from harness.client import Client, job, quadratic_surface, tool
from harness.process import NodeProcess
from toolpath_bin import toolpath_bin

ROOT = Path(__file__).resolve().parents[2]
BAGS = sorted(p for p in (ROOT / "bags").iterdir() if (p / "metadata.yaml").is_file())


# mcap-ros2-support (0.6) parses schemas with the .msg grammar, whose type names
# have no underscore: it cannot decode the types rosidl derives for an action's
# topics (`pkg/action/Type_FeedbackMessage`); rosbags decodes them.
DERIVED_TYPES = ("toolpath_msgs/action/PlanToolpath_FeedbackMessage",)


def decode_with_mcap_ros2(bag):
    """[(topic, message)] of the bag's .mcap, decoded by mcap-ros2-support
    (the action's feedback topic left out: see DERIVED_TYPES)."""
    mcap_file = bag / f"{bag.name}_0.mcap"
    out = []
    with open(mcap_file, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        for schema in summary.schemas.values():
            assert schema.encoding == "ros2msg"
        for channel in summary.channels.values():
            assert channel.message_encoding == "cdr"
            assert "offered_qos_profiles" in channel.metadata
        decodable = {c.topic for c in summary.channels.values()
                     if summary.schemas[c.schema_id].name not in DERIVED_TYPES}
        for schema, channel, message, msg in reader.iter_decoded_messages(topics=sorted(decodable)):
            out.append((channel.topic, msg))
            if channel.topic == "/toolpath":
                assert sum(len(p.points) for p in msg.passes) == msg.stats.points
        counts = summary.statistics.channel_message_counts
        assert len(out) == sum(n for cid, n in counts.items() if summary.channels[cid].topic in decodable)
    return out


def decode_with_rosbags(bag):
    """[(topic, message)] of the bag directory and of its bare .mcap, by rosbags."""
    store = get_typestore(Stores.ROS2_JAZZY)
    out = []
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
                out.append((conn.topic, msg))
                count += 1
            assert count == reader.message_count > 0
    return out


def test_there_are_golden_bags():
    assert len(BAGS) >= 7


@pytest.mark.parametrize("bag", BAGS, ids=[b.name for b in BAGS])
def test_mcap_ros2_decodes_every_message(bag):
    got = decode_with_mcap_ros2(bag)
    topics = {t for t, _ in got}
    for t, m in got:
        if t == "/job":
            assert m.job_id == bag.name
    assert {"/job", "/job_status"} <= topics


@pytest.mark.parametrize("bag", BAGS, ids=[b.name for b in BAGS])
def test_rosbags_decodes_every_message(bag):
    decode_with_rosbags(bag)


def test_a_bag_recorded_by_the_node_decodes(tmp_path):
    config = 'recording:\n  enabled: true\n  directory: "%s"\n  bag_name: node_run\n' % tmp_path
    proc = NodeProcess(config_text=config)
    c = Client(proc.domain_id)
    try:
        assert "recording to %s" % (tmp_path / "node_run") in proc.ready_line
        c.wait_for_node()
        c.send_surface(quadratic_surface("rec_trough", 0, 40, -20, 20, ky=0.01))
        c.send_job(job("rec_ok", "rec_trough", "iso_parametric", tool("flat_end", radius=2.5),
                       scallop=0.5, lead_angle_deg=5.0, feed_direction="u"))
        c.send_job(job("rec_bad", "rec_trough", "spiral", tool("ball", radius=1.0)))
        got = c.wait_final(["rec_ok", "rec_bad"], timeout=120)
        assert got["rec_ok"].state == msgs.JobStatus.SUCCEEDED, got["rec_ok"].message
        assert got["rec_bad"].state == msgs.JobStatus.REJECTED
        goals = action.ActionClient(c.node._dp, "/")
        goals.wait()
        goal_id, accepted = goals.send(action.Goal(
            job=job("rec_goal", "rec_trough", "iso_parametric", tool("flat_end", radius=2.5), scallop=0.5,
                    lead_angle_deg=5.0, feed_direction="u"), surface=[]))
        assert accepted
        status, result = goals.result(goal_id)
        assert status == action.STATUS_SUCCEEDED, result.reason
    finally:
        c.close()
        proc.stop()  # SIGTERM: the node writes metadata.yaml
    bag = tmp_path / "node_run"
    assert (bag / "metadata.yaml").is_file()
    # rosbags reads the bag twice: as a directory and as its bare .mcap.
    for decoded, copies in ((decode_with_mcap_ros2(bag), 1), (decode_with_rosbags(bag), 2)):
        topics = {t for t, _ in decoded}
        assert {"/surface", "/job", "/toolpath", "/tool_poses", "/mill5/joint_trajectory", "/markers",
                "/job_status"} <= topics
        finals = {m.job_id: m.state for t, m in decoded if t == "/job_status" and m.state >= 2}
        assert finals == {"rec_ok": 2, "rec_bad": 4, "rec_goal": 2}
        jobs = [m.job_id for t, m in decoded if t == "/job"]
        assert sorted(set(jobs)) == ["rec_bad", "rec_goal", "rec_ok"]
        # The goal's states in order: accepted, executing, succeeded (each array lists
        # every goal the server holds, so a state may repeat).
        states = [s.status for t, m in decoded if t == "/plan_toolpath/_action/status"
                  for s in m.status_list if bytes(s.goal_info.goal_id.uuid) == bytes(goal_id.uuid)]
        changes = [s for k, s in enumerate(states) if k == 0 or states[k - 1] != s]
        assert changes == [action.STATUS_ACCEPTED, action.STATUS_EXECUTING, action.STATUS_SUCCEEDED] * copies, states
    # The goal's feedback, tagged with its id, from "queued" on.
    feedback = [m for t, m in decode_with_rosbags(bag) if t == "/plan_toolpath/_action/feedback"]
    assert feedback and all(bytes(m.goal_id.uuid) == bytes(goal_id.uuid) for m in feedback)
    assert feedback[0].feedback.stage == "queued"
    assert {"planning"} <= {m.feedback.stage for m in feedback}
    assert all(0.0 <= m.feedback.progress <= 1.0 for m in feedback)
    # Replay knows the action's topics and re-plans the three jobs alike.
    replay = subprocess.run([toolpath_bin(), "replay", "--check", str(bag)], capture_output=True, text=True,
                            timeout=300)
    assert replay.returncode == 0, replay.stdout + replay.stderr
