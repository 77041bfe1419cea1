"""The node as a ROS 2 node, checked from a Cyclone DDS peer on loopback (what
an rclpy node or the ros2 CLI looks like on the wire): the --ros-args forms,
the parameter services (list, get, set), /rosout, and ROS's default QoS on
the shape inputs."""

import os
import subprocess
import time

import pytest
import yaml

from harness import msgs, rcl
from harness.client import Client, job, quadratic_surface, tool
from harness.msgs import ROOT
from harness.process import NodeProcess, binary
from harness.ros import QOS_READ_ALL, QoSProfile, Node

NS, NAME = "/cell_b", "tp"
FQ = NS + "/" + NAME
# rclpy's default publisher QoS: reliable, volatile, keep-last 10.
ROS_DEFAULT = QoSProfile(depth=10)

PARAMS_FILE = """\
/**:
  ros__parameters:
    node:
      surface_timeout_s: 7.5
    mill5.retract_mm: 12.5
/other_node:
  ros__parameters:
    node.surface_timeout_s: 99.0
"""


def flat_names(tree, prefix=""):
    """Dotted names of the leaves of a YAML mapping."""
    out = []
    for k, v in tree.items():
        name = prefix + str(k)
        if isinstance(v, dict):
            out += flat_names(v, name + ".")
        else:
            out.append(name)
    return out


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """A node started as `ros2 run` would with remaps, a params file and -p."""
    params = tmp_path_factory.mktemp("params") / "tp.yaml"
    params.write_text(PARAMS_FILE)
    proc = NodeProcess(
        ros_args=[
            "-r", "__ns:=" + NS,
            "-r", "__node:=" + NAME,
            "--params-file", str(params),
            "-p", "node.verify:=false",
            "-p", "node.workers:=2",
            "-r", "job_status:=status",
        ]
    )
    # Stopped however the setup ends: a failed wait must not leave the node running.
    peer = None
    try:
        peer = Node("ros_conventions_test", namespace=NS, domain_id=proc.domain_id)
        from cyclonedds.core import Policy, Qos
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration

        # /diagnostics with ROS's default subscription QoS (reliable, volatile, keep last 10).
        diagnostics = DataReader(
            peer._dp,
            Topic(peer._dp, "rt/diagnostics", msgs.DiagnosticArray),
            qos=Qos(Policy.Reliability.Reliable(duration(seconds=5)), Policy.Durability.Volatile,
                    Policy.History.KeepLast(10)),
        )
        # /rosout as `ros2 topic echo /rosout` reads it (reliable, transient-local).
        rosout = DataReader(
            peer._dp,
            Topic(peer._dp, "rt/rosout", rcl.Log),
            qos=Qos(Policy.Reliability.Reliable(duration(seconds=5)), Policy.Durability.TransientLocal,
                    Policy.History.KeepLast(1000)),
        )
        params_client = rcl.ParameterClient(peer._dp, FQ)
        params_client.wait()
        statuses = {}
        peer.create_subscription(msgs.JobStatus, "status", lambda m: statuses.setdefault(m.job_id, []).append(m),
                                 QOS_READ_ALL)
        job_pub = peer.create_publisher(msgs.Job, "job", QoSProfile(keep_all=True))
        assert peer.spin_until(lambda: job_pub.get_subscription_count() > 0, 20), "job reader not matched"
        yield {"proc": proc, "peer": peer, "params": params_client, "rosout": rosout, "statuses": statuses,
               "job_pub": job_pub, "logs": [],
               "diagnostics": diagnostics}
    finally:
        if peer is not None:
            peer.destroy_node()
        proc.stop()


def wait_final(cell, job_id, timeout=60.0):
    final = (msgs.JobStatus.SUCCEEDED, msgs.JobStatus.FAILED, msgs.JobStatus.REJECTED)
    peer, statuses = cell["peer"], cell["statuses"]
    done = lambda: any(s.state in final for s in statuses.get(job_id, []))  # noqa: E731
    assert peer.spin_until(done, timeout), "no final status of %s on %s/status" % (job_id, NS)
    return [s for s in statuses[job_id] if s.state in final][-1]


def rosout_lines(cell, timeout, predicate):
    """/rosout records received so far (and up to `timeout` more seconds until one matches)."""
    deadline = time.monotonic() + timeout
    while True:
        cell["logs"] += cell["rosout"].take(N=1000)
        if any(predicate(m) for m in cell["logs"]) or time.monotonic() > deadline:
            return cell["logs"]
        time.sleep(0.05)


def test_the_node_runs_under_the_remapped_name_and_namespace(cell):
    assert "node %s on ROS domain %d" % (FQ, cell["proc"].domain_id) in cell["proc"].ready_line


def test_every_config_setting_is_a_listed_parameter(cell):
    names = cell["params"].list()
    with open(os.path.join(ROOT, "launch_configs", "default.yaml")) as fh:
        settings = flat_names(yaml.safe_load(fh))
    missing = sorted(set(settings) - set(names))
    assert not missing, missing
    assert "use_sim_time" in names
    assert len(names) == len(set(names))


def test_describe_gives_the_config_comment_the_range_and_read_only(cell):
    d = {x.name: x for x in cell["params"].describe(
        "node.workers", "node.surface_timeout_s", "mill5.a.max_velocity_deg_s", "recording.zstd_level")}
    workers = d["node.workers"]
    assert workers.description == "planning threads; 0 = one per available core", workers
    assert workers.type == rcl.INTEGER and not workers.read_only
    assert [(r.from_value, r.to_value, r.step) for r in workers.integer_range] == [(0, 256, 1)], workers
    pivot, = cell["params"].describe("mill5.pivot_length_mm")
    assert pivot.read_only and "read-only while the node runs" in pivot.additional_constraints, pivot
    timeout = d["node.surface_timeout_s"]
    assert not timeout.read_only and timeout.type == rcl.DOUBLE, timeout
    assert [r.from_value for r in timeout.floating_point_range] == [0.0], timeout
    assert d["mill5.a.max_velocity_deg_s"].description == "axis A: velocity limit, degrees/s"
    assert [(r.from_value, r.to_value) for r in d["recording.zstd_level"].integer_range] == [(0, 19)]
    # A name that is not a parameter: ros2-client's "unknown parameter", type NOT_SET.
    (unknown,) = cell["params"].describe("no.such_parameter")
    assert unknown.type == rcl.NOT_SET, unknown


def test_values_come_from_the_params_file_and_p_rules(cell):
    got = cell["params"].get(
        "node.verify", "node.surface_timeout_s", "mill5.retract_mm", "node.name", "node.namespace",
        "mill5.workpiece_origin_mm", "node.interfaces", "node.workers", "no.such_parameter",
    )
    assert got == [False, 7.5, 12.5, NAME, NS, [2500.0, 1000.0, 300.0], ["127.0.0.1"], 2, None]


def test_bad_sets_are_refused_with_the_reason_and_change_nothing(cell):
    p = cell["params"]
    ok, why = p.set("mill5.pivot_length_mm", 300.0)
    assert not ok and "mill5.pivot_length_mm is read-only" in why and "machine geometry" in why, why
    ok, why = p.set("node.workers", 100000)
    assert not ok and "node.workers: 100000 is above the limit" in why, why
    ok, why = p.set("node.surface_timeout_s", -1.0)
    assert not ok and "node.surface_timeout_s: must be a finite number >= 0" in why, why
    ok, why = p.set("node.verify", "yes")
    assert not ok and why, why
    ok, why = p.set("no.such_parameter", 1)
    assert not ok and why, why
    assert p.get("mill5.pivot_length_mm", "node.workers", "node.surface_timeout_s", "node.verify") == [
        250.0, 2, 7.5, False]
    assert cell["proc"].alive()


def test_a_run_time_set_takes_effect_for_the_next_job_and_is_logged_on_rosout(cell):
    ok, why = cell["params"].set("node.surface_timeout_s", 1.0)
    assert ok, why
    assert cell["params"].get("node.surface_timeout_s") == [1.0]
    t0 = time.monotonic()
    cell["job_pub"].publish(job("orphan", "never_sent", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
    final = wait_final(cell, "orphan", timeout=30)
    assert final.state == msgs.JobStatus.FAILED
    assert final.message.startswith('surface "never_sent" has not arrived within 1 s'), final.message
    assert time.monotonic() - t0 < 7.0  # not the 7.5 s of the params file

    want = "parameter node.surface_timeout_s set to"
    logs = rosout_lines(cell, 10, lambda m: want in m.msg)
    mine = [m for m in logs if want in m.msg]
    assert mine, [m.msg for m in logs]
    m = mine[0]
    assert m.level == rcl.INFO
    assert m.name == "cell_b.tp"  # rclcpp's logger name of /cell_b/tp
    assert m.file.endswith(".rs") and m.line > 0 and m.function
    assert m.stamp.sec > 1_600_000_000


def test_a_publisher_with_ros_default_qos_on_surface_is_received(cell):
    peer = cell["peer"]
    pub = peer.create_publisher(msgs.Surface, "surface", ROS_DEFAULT)
    assert peer.spin_until(lambda: pub.get_subscription_count() > 0, 20), "default-QoS surface writer not matched"
    pub.publish(quadratic_surface("default_qos_surface", 0, 40, -20, 20, ky=0.01))
    cell["job_pub"].publish(job("on_default_qos", "default_qos_surface", "iso_scallop", tool("ball", radius=3.0),
                                scallop=0.05))
    final = wait_final(cell, "on_default_qos", timeout=120)
    assert final.state == msgs.JobStatus.SUCCEEDED, final.message
    # Received once, though both of the node's surface readers match this writer.
    assert cell["proc"].log().count("received default_qos_surface") == 1, cell["proc"].log()


def test_a_transient_local_surface_published_before_the_node_starts_is_received():
    from harness.process import random_domain

    domain = random_domain()
    early = Client(domain)
    early.send_surface(quadratic_surface("early_surface", 0, 40, -20, 20, ky=0.01))
    proc = NodeProcess(domain_id=domain, ros_args=["-p", "node.verify:=false"])
    try:
        early.wait_for_node()
        early.send_job(job("on_early", "early_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
        got = early.wait_final(["on_early"], timeout=120)["on_early"]
        assert got.state == msgs.JobStatus.SUCCEEDED, got.message
        assert proc.log().count("received early_surface") == 1, proc.log()
    finally:
        early.close()
        proc.stop()


@pytest.mark.parametrize(
    "args, reason",
    [
        (["-p", "node.workers:=lots"], '--ros-args -p node.workers: node.workers: invalid type: string "lots"'),
        (["-p", "node.wrokers:=2"], "--ros-args -p node.wrokers: is not a parameter of this node"),
        (["-p", "node.workers=2"], 'expected NAME:=VALUE (the separator is ":=")'),
        (["-r", "__ns:=cell"], "-r __ns:=cell: the namespace must be absolute"),
        (["--params-file", "/nonexistent/tp.yaml"], "/nonexistent/tp.yaml: No such file"),
        (["--log-level", "loud"], '"loud" is not a log level'),
        (["--frobnicate"], "--ros-args --frobnicate: is not a ROS argument"),
    ],
)
def test_bad_ros_args_stop_the_node_with_the_reason(args, reason):
    env = dict(os.environ, ROS_DOMAIN_ID="0")
    r = subprocess.run([binary(), "node", "--ros-args"] + args, env=env, capture_output=True, text=True,
                       timeout=30)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert reason in r.stderr, r.stderr
    assert "ready" not in r.stdout


def test_diagnostics_report_the_node_once_a_second(cell):
    """Runs after jobs were planned above: the counts are of this node's life."""
    reader = cell["diagnostics"]
    reader.take(N=100)
    got, deadline = [], time.monotonic() + 5.0
    while len(got) < 3 and time.monotonic() < deadline:
        got += reader.take(N=10)
        time.sleep(0.05)
    assert len(got) >= 3, "%d DiagnosticArray in 5 s" % len(got)
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in got]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    assert all(0.8 < g < 1.2 for g in gaps), gaps
    m = got[-1]
    assert len(m.status) == 1
    s = m.status[0]
    assert (s.level, s.name, s.hardware_id, s.message) == (msgs.DiagnosticStatus.OK, "tp: planner", FQ, "idle")
    v = {kv.key: kv.value for kv in s.values}
    assert v["queued jobs"] == "0" and v["busy workers"] == "0" and v["workers"] == "2"
    # orphan (timed out, not planned) and on_default_qos (planned) ran before.
    assert int(v["jobs planned"]) >= 1, v
    assert 0.0 < float(v["last planning time s"]) < 60.0, v
    assert v["recorder"] == "off"
    # This test's peer: one job writer, one reader of the remapped job_status.
    assert v["discovered publishers /cell_b/job"] == "1", v
    assert v["discovered subscribers /cell_b/status"] == "1", v
    assert v["discovered subscribers /cell_b/toolpath"] == "0", v


def test_a_job_for_another_node_is_ignored_and_one_for_this_node_planned(cell):
    peer = cell["peer"]
    pub = peer.create_publisher(msgs.Surface, "surface", ROS_DEFAULT)
    assert peer.spin_until(lambda: pub.get_subscription_count() > 0, 20), "surface writer not matched"
    pub.publish(quadratic_surface("addressed_surface", 0, 40, -20, 20, ky=0.01))
    other = job("for_other", "addressed_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05)
    other.node = "/cell_a/" + NAME
    cell["job_pub"].publish(other)
    mine = job("for_me", "addressed_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05)
    mine.node = FQ
    cell["job_pub"].publish(mine)
    final = wait_final(cell, "for_me", timeout=120)
    assert final.state == msgs.JobStatus.SUCCEEDED, final.message
    # The other node's job was published first: by now it would have a status.
    peer.spin_until(lambda: False, 1.0)
    assert "for_other" not in cell["statuses"], cell["statuses"].get("for_other")


def test_a_best_effort_publisher_on_a_reliable_input_is_logged_as_incompatible(cell):
    """DDS does not match a best-effort writer with a reliable reader; the node says so on its log."""
    peer, proc = cell["peer"], cell["proc"]
    # A ROS-default (volatile) writer matches the volatile one of the node's two
    # surface readers and not its transient-local one, by design: not reported.
    default = peer.create_publisher(msgs.Surface, "surface", ROS_DEFAULT)
    assert peer.spin_until(lambda: default.get_subscription_count() > 0, 20)
    time.sleep(0.5)
    assert "durability: requested TransientLocal" not in proc.log(), proc.log()[-2000:]
    peer.create_publisher(msgs.Surface, "surface", QoSProfile(depth=10, reliable=False))
    want = "incompatible QoS on DDS topic rt%s/surface" % NS
    deadline = time.monotonic() + 20
    while want not in proc.log():
        assert time.monotonic() < deadline, "no incompatible-QoS line in the node's log:\n" + proc.log()[-2000:]
        time.sleep(0.1)
    line = next(ln for ln in proc.log().splitlines() if want in ln)
    assert "remote writer" in line and "reliability: requested Reliable, offered BestEffort" in line, line
    assert "WARN" in line, line


def test_tf_static_places_the_workpiece_for_a_late_listener(cell):
    """/tf_static as tf2's static listener reads it (reliable, transient-local,
    keep last 1), joining long after the node published: mill5_base ->
    workpiece -> belt6_base with the default config's poses, in metres."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    peer = cell["peer"]
    reader = DataReader(
        peer._dp,
        Topic(peer._dp, "rt/tf_static", msgs.get("tf2_msgs/TFMessage")),
        qos=Qos(Policy.Reliability.Reliable(duration(seconds=5)), Policy.Durability.TransientLocal,
                Policy.History.KeepLast(1)),
    )
    got, deadline = [], time.monotonic() + 10.0
    while not got and time.monotonic() < deadline:
        got = reader.take(N=10)
        time.sleep(0.05)
    assert len(got) == 1, "%d TFMessage on /tf_static" % len(got)
    tf = {(t.header.frame_id, t.child_frame_id): t.transform for t in got[0].transforms}
    assert sorted(tf) == [("mill5_base", "workpiece"), ("workpiece", "belt6_base")], sorted(tf)
    # default.yaml: mill5 workpiece_origin_mm [2500, 1000, 300], belt6 [1500, 1000, 400], no turn.
    for key, want in ((("mill5_base", "workpiece"), (2.5, 1.0, 0.3)), (("workpiece", "belt6_base"), (-1.5, -1.0, -0.4))):
        t = tf[key]
        assert (t.translation.x, t.translation.y, t.translation.z) == pytest.approx(want, abs=1e-12), key
        assert (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w) == (0.0, 0.0, 0.0, 1.0), key


def test_inputs_in_a_machine_frame_are_moved_and_unknown_frames_refused(cell):
    peer = cell["peer"]
    pub = peer.create_publisher(msgs.Surface, "surface", ROS_DEFAULT)
    assert peer.spin_until(lambda: pub.get_subscription_count() > 0, 20), "surface writer not matched"
    # The same patch in mill5's machine coordinates (workpiece origin at 2500, 1000, 300).
    in_machine = quadratic_surface("machine_frame_surface", 0, 40, -20, 20, ky=0.01)
    in_machine.header.frame_id = "mill5_base"
    for p in in_machine.control_points:
        p.x, p.y, p.z = p.x + 2500.0, p.y + 1000.0, p.z + 300.0
    pub.publish(in_machine)
    fixture = quadratic_surface("fixture_frame_surface", 0, 40, -20, 20, ky=0.01)
    fixture.header.frame_id = "fixture"
    pub.publish(fixture)
    cell["job_pub"].publish(job("on_machine_frame", "machine_frame_surface", "iso_scallop", tool("ball", radius=3.0),
                                scallop=0.05))
    cell["job_pub"].publish(job("on_fixture_frame", "fixture_frame_surface", "iso_scallop", tool("ball", radius=3.0),
                                scallop=0.05))
    in_world = job("job_in_world", "machine_frame_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05)
    in_world.header.frame_id = "world"
    cell["job_pub"].publish(in_world)
    final = wait_final(cell, "on_fixture_frame")
    assert final.state == msgs.JobStatus.REJECTED, final.message
    assert "surface.header.frame_id" in final.message and '"fixture"' in final.message, final.message
    final = wait_final(cell, "job_in_world")
    assert final.state == msgs.JobStatus.REJECTED, final.message
    assert "job.header.frame_id" in final.message and "mill5_base" in final.message, final.message
    final = wait_final(cell, "on_machine_frame", timeout=120)
    assert final.state == msgs.JobStatus.SUCCEEDED, final.message


def diagnostic_values(cell, timeout, predicate):
    """The values of the latest /diagnostics status that satisfies `predicate` (or the last one)."""
    reader, last, deadline = cell["diagnostics"], None, time.monotonic() + timeout
    while time.monotonic() < deadline:
        for m in reader.take(N=10):
            last = {kv.key: kv.value for kv in m.status[0].values}
            if predicate(last):
                return last
        time.sleep(0.05)
    return last


def test_workers_set_at_run_time_resize_the_pool_and_jobs_are_still_served(cell):
    """Runs last: it leaves node.workers as the fixture set it."""
    p = cell["params"]
    for count in (3, 1, 2):
        ok, why = p.set("node.workers", count)
        assert ok, why
        assert p.get("node.workers") == [count]
        # /diagnostics counts the planning threads running, not the setting.
        v = diagnostic_values(cell, 5.0, lambda v: v["workers"] == str(count))
        assert v is not None and v["workers"] == str(count), v
        name = "after_workers_%d" % count
        cell["job_pub"].publish(job(name, "default_qos_surface", "iso_scallop", tool("ball", radius=3.0),
                                    scallop=0.05))
        final = wait_final(cell, name, timeout=120)
        assert final.state == msgs.JobStatus.SUCCEEDED, final.message
