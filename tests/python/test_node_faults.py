"""The node under faults, as an operator would try it: SIGKILL at random
moments and a restart on the same job journal, frames lost, duplicated,
reordered and delayed by a relay between network namespaces, fuzzed
payloads on every endpoint, and concurrent clients.

What must hold: every accepted job gets exactly one final status (a
restarted node may publish a final again, as the same message: same stamp,
same text); a job planned again after a crash gives the same toolpath as
without it; every status a client saw is in the node's bags after
`toolpath bag reindex`.
"""

import os
import random
import signal
import subprocess
import sys
import time

import pytest

# The journal's restart path is unfinished (issue 42): a job planned again after SIGKILL does not
# yet give the bytes of a run without the crash. Expected to fail until it does.
pytestmark = pytest.mark.xfail(reason="job journal restart unfinished: re-planned jobs differ", strict=False)
from cyclonedds.idl import types as t

from harness import faults, msgs, netns
from harness.client import Client, job, quadratic_surface, tool
from harness.process import NodeProcess, random_domain
from toolpath_bin import toolpath_bin

SURFACE = "fault_surface"
# Planned one after another (one worker): long enough that a queue forms,
# short enough for ten trials in a few minutes.
CRASH_JOBS = 5


def crash_surface():
    return quadratic_surface(SURFACE, 0, 60, -25, 25, kx=0.004, ky=0.01)


def crash_job(k):
    return job("crash_%02d" % k, SURFACE, "iso_scallop", tool("ball", radius=3.0), scallop=0.02)


def journal_config(directory, on_restart="replan"):
    return (
        "node:\n  workers: 1\n"
        'recording:\n  enabled: true\n  directory: "%s"\n'
        'journal:\n  path: "%s"\n  on_restart: %s\n' % (directory, os.path.join(directory, "journal.redb"), on_restart)
    )


@pytest.fixture(scope="module")
def reference_toolpaths():
    """The crash jobs' toolpaths from a node that is never killed."""
    node = NodeProcess(config_text="node:\n  workers: 1\n")
    c = Client(node.domain_id)
    try:
        c.wait_for_node()
        c.send_surface(crash_surface())
        ids = [crash_job(k).job_id for k in range(CRASH_JOBS)]
        for k in range(CRASH_JOBS):
            c.send_job(crash_job(k))
        got = c.wait_final(ids, timeout=120)
        assert all(s.state == msgs.JobStatus.SUCCEEDED for s in got.values()), got
        assert c.node.spin_until(lambda: all(j in c.toolpaths for j in ids), 20)
        return {j: faults.comparable(c.toolpaths[j]) for j in ids}
    finally:
        c.close()
        node.stop()


def kill_when(c, node, phase, rng, ids):
    """Spins `c` until the moment of `phase`, then SIGKILLs the node: after
    every job was ACCEPTED (queued), after a RUNNING status (planning), as a
    toolpath arrives (publishing), just after a final status (recording)."""
    k = rng.randrange(1, CRASH_JOBS - 1)

    def states(j):
        return [s.state for s in c.statuses.get(j, [])]

    trigger = {
        "queued": lambda: all(msgs.JobStatus.ACCEPTED in states(j) for j in ids),
        "planning": lambda: msgs.JobStatus.RUNNING in states(ids[k]),
        "publishing": lambda: ids[k] in c.toolpaths,
        "recording": lambda: any(s >= msgs.JobStatus.SUCCEEDED for s in states(ids[k])),
    }[phase]
    assert c.node.spin_until(trigger, 120), "the %s moment never came: %s" % (phase, c.statuses)
    time.sleep(rng.uniform(0.0, {"queued": 0.05, "planning": 0.2, "publishing": 0.005, "recording": 0.003}[phase]))
    os.kill(node.pid, signal.SIGKILL)
    node.proc.wait()


def crash_trial(tmp_path, phase, seed, reference):
    rng = random.Random(seed)
    directory = str(tmp_path)
    config = journal_config(directory)
    domain = random_domain()
    first = NodeProcess(domain_id=domain, config_text=config)
    c = Client(domain)
    second = None
    try:
        c.wait_for_node()
        c.send_surface(crash_surface())
        ids = [crash_job(k).job_id for k in range(CRASH_JOBS)]
        for k in range(CRASH_JOBS):
            c.send_job(crash_job(k))
        kill_when(c, first, phase, rng, ids)
        accepted = [j for j in ids if any(s.state == msgs.JobStatus.ACCEPTED for s in c.statuses.get(j, []))]
        second = NodeProcess(domain_id=domain, config_text=config)
        # A restarted node has no shapes: the client publishes its surface again.
        c.send_surface(crash_surface())
        assert c.node.spin_until(lambda: all(faults.distinct_finals(c.statuses.get(j, [])) for j in accepted), 120), (
            "no final status after the restart: %s" % {j: [(s.state, s.message) for s in c.statuses.get(j, [])]
                                                       for j in accepted})
        c.node.spin_until(lambda: False, 1.0)
        for j in accepted:
            finals = faults.distinct_finals(c.statuses[j])
            assert len(finals) == 1, "%s: %s" % (j, [(s.state, s.message) for s in finals])
            assert finals[0].state == msgs.JobStatus.SUCCEEDED, (j, finals[0].message)
            assert c.node.spin_until(lambda: j in c.toolpaths, 20), j
            assert faults.comparable(c.toolpaths[j]) == reference[j], "%s planned again differs" % j
        replanned = [j for j in accepted if any("node restarted" in s.message for s in c.statuses[j])]
    finally:
        c.close()
        if second is not None:
            second.stop()
    seen = {faults.status_key(s) for j in c.statuses for s in c.statuses[j]}
    for bag in sorted(p for p in os.listdir(directory) if os.path.isdir(os.path.join(directory, p))):
        faults.reindex(toolpath_bin(), os.path.join(directory, bag))
    missing = seen - faults.bag_statuses(directory)
    assert not missing, "statuses a client saw but no bag holds: %s" % sorted(missing)[:5]
    return len(accepted), len(replanned)


TRIALS = [("queued", 1), ("queued", 2), ("queued", 3), ("planning", 4), ("planning", 5), ("planning", 6),
          ("publishing", 7), ("publishing", 8), ("recording", 9), ("recording", 10)]


@pytest.mark.parametrize("phase,seed", TRIALS, ids=["%s-%d" % p for p in TRIALS])
def test_sigkill_then_restart_every_accepted_job_ends_once(tmp_path, phase, seed, reference_toolpaths):
    accepted, replanned = crash_trial(tmp_path, phase, seed, reference_toolpaths)
    print("FIGURE sigkill %s seed %d: %d accepted, %d planned again after the restart" % (
        phase, seed, accepted, replanned))
    assert accepted > 0
    if phase == "queued":
        assert replanned > 0


def test_a_restart_told_to_fail_ends_unfinished_jobs_failed(tmp_path):
    directory = str(tmp_path)
    domain = random_domain()
    first = NodeProcess(domain_id=domain, config_text=journal_config(directory, "fail"))
    c = Client(domain)
    second = None
    try:
        c.wait_for_node()
        c.send_surface(crash_surface())
        ids = [crash_job(k).job_id for k in range(CRASH_JOBS)]
        for k in range(CRASH_JOBS):
            c.send_job(crash_job(k))
        kill_when(c, first, "queued", random.Random(0), ids)
        second = NodeProcess(domain_id=domain, config_text=journal_config(directory, "fail"))
        assert c.node.spin_until(lambda: all(faults.distinct_finals(c.statuses.get(j, [])) for j in ids), 60)
        c.node.spin_until(lambda: False, 0.5)
        failed = 0
        for j in ids:
            finals = faults.distinct_finals(c.statuses[j])
            assert len(finals) == 1, (j, finals)
            if finals[0].state == msgs.JobStatus.FAILED:
                assert finals[0].message == "node restarted before finishing", finals[0].message
                failed += 1
            else:
                assert finals[0].state == msgs.JobStatus.SUCCEEDED
        assert failed > 0
    finally:
        c.close()
        if second is not None:
            second.stop()


def test_a_goal_sent_again_after_a_restart_ends_with_its_job(tmp_path):
    from harness import action

    directory = str(tmp_path)
    domain = random_domain()
    first = NodeProcess(domain_id=domain, config_text=journal_config(directory))
    c = Client(domain)
    second = None
    try:
        c.wait_for_node()
        c.send_surface(crash_surface())
        goals = action.ActionClient(c.node._dp, "/")
        goals.wait()
        sent = []
        for k in range(3):
            goal = action.Goal(job=crash_job(k), surface=[])
            goal_id, accepted = goals.send(goal)
            assert accepted
            sent.append((goal_id, goal))
        ids = [g.job.job_id for _, g in sent]
        kill_when(c, first, "queued", random.Random(3), ids)
        second = NodeProcess(domain_id=domain, config_text=journal_config(directory))
        c.send_surface(crash_surface())
        goals = action.ActionClient(c.node._dp, "/")
        goals.wait()
        for goal_id, goal in sent:
            r = goals.send_goal.call(action.SendGoal_Request(goal_id=goal_id, goal=goal))
            assert r.accepted
        for goal_id, goal in sent:
            status, result = goals.result(goal_id)
            assert status == action.STATUS_SUCCEEDED, (goal.job.job_id, result.reason)
        assert c.node.spin_until(lambda: all(faults.distinct_finals(c.statuses.get(j, [])) for j in ids), 30)
        c.node.spin_until(lambda: False, 0.5)
        for j in ids:
            assert len(faults.distinct_finals(c.statuses[j])) == 1, j
    finally:
        c.close()
        if second is not None:
            second.stop()


def test_a_second_job_under_a_queued_id_gets_no_final_of_its_own():
    node = NodeProcess(config_text="node:\n  workers: 1\n")
    c = Client(node.domain_id)
    try:
        c.wait_for_node()
        c.send_surface(crash_surface())
        first = crash_job(0)
        other = crash_job(0)
        other.scallop = 0.05
        c.send_job(crash_job(1))
        c.send_job(first)
        c.send_job(other)
        c.send_job(first)  # the same job again: answered by the first's statuses
        got = c.wait_final(["crash_00", "crash_01"], timeout=120)
        c.node.spin_until(lambda: False, 0.5)
        finals = faults.distinct_finals(c.statuses["crash_00"])
        assert len(finals) == 1 and finals[0].state == msgs.JobStatus.SUCCEEDED, finals
        refused = [s for s in c.statuses["crash_00"] if "this second job is refused" in s.message]
        assert len(refused) == 1, [(s.state, s.message) for s in c.statuses["crash_00"]]
        assert refused[0].state in (msgs.JobStatus.ACCEPTED, msgs.JobStatus.RUNNING)
        assert got["crash_00"].message.startswith("1 ") or "passes" in got["crash_00"].message
    finally:
        c.close()
        node.stop()


LOSSY_JOBS = 50


def test_jobs_through_a_lossy_reordering_link_each_end_once(tmp_path):
    ok, why = netns.available()
    if not ok:
        pytest.skip("no network namespaces here (%s): the lossy-link test needs `ip netns` as root" % why)
    link = netns.LossyLink(random.SystemRandom().randint(1, 250), loss=0.3, dup=0.07, reorder=0.35,
                           delay_ms=(5.0, 20.0), seed=42)
    domain = random_domain()
    node = out = None
    try:
        config = os.path.join(str(tmp_path), "cell.yaml")
        with open(config, "w") as fh:
            fh.write("node:\n  interfaces: [%s]\n  workers: 2\n" % link.node_ip)
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), RUST_LOG="off")
        node = subprocess.Popen(link.in_node_ns([toolpath_bin(), "node", "--config", config]), env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        assert node.stdout.readline().startswith("ready")
        out = os.path.join(str(tmp_path), "client.json")
        client_env = dict(os.environ, CYCLONEDDS_URI=link.cyclone_uri(),
                          PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(netns.__file__))))
        started = time.monotonic()
        r = subprocess.run(link.in_client_ns([sys.executable, "-m", "harness.netns_client", str(domain), out,
                                              "--jobs", str(LOSSY_JOBS), "--timeout", "90"]),
                           env=client_env, capture_output=True, text=True, timeout=150)
        took = time.monotonic() - started
        assert r.returncode == 0, r.stderr[-2000:]
    finally:
        if node is not None:
            node.kill()
            node.wait()
        link.close()
    import json

    with open(out) as fh:
        seen = json.load(fh)
    stats = link.relay_stats()
    lost = [j for j, ss in seen["statuses"].items() if not any(s[0] in faults.FINAL_STATES for s in ss)]
    assert not lost, "no final status for %s" % lost[:5]
    for j, ss in seen["statuses"].items():
        finals = {tuple(s) for s in ss if s[0] in faults.FINAL_STATES}
        assert len(finals) == 1, (j, finals)
        assert next(iter(finals))[0] == msgs.JobStatus.SUCCEEDED, (j, finals)
    print("FIGURE lossy link: %d of %d jobs ended once in %.1f s; relay %s" % (
        LOSSY_JOBS - len(lost), LOSSY_JOBS, took, stats))
    assert stats["lost"] > 0 and stats["duplicated"] > 0 and stats["reordered"] > 0


def fuzz_type(typename):
    return msgs.struct("Fuzz", typename, [("data", t.sequence[t.uint8], list)])


# (DDS topic, type) of every endpoint the node reads, relative to the node
# `/toolpath_planner` in the root namespace.
FUZZED = [
    ("rt/surface", "toolpath_msgs::msg::dds_::Surface_"),
    ("rt/pocket", "toolpath_msgs::msg::dds_::Pocket_"),
    ("rt/job", "toolpath_msgs::msg::dds_::Job_"),
    ("rt/cancel", "std_msgs::msg::dds_::String_"),
    ("rt/joint_states", "sensor_msgs::msg::dds_::JointState_"),
    ("rq/plan_toolpathRequest", "toolpath_msgs::srv::dds_::PlanToolpath_Request_"),
    ("rq/plan_toolpath/_action/send_goalRequest", "toolpath_msgs::action::dds_::PlanToolpath_SendGoal_Request_"),
    ("rq/plan_toolpath/_action/get_resultRequest", "toolpath_msgs::action::dds_::PlanToolpath_GetResult_Request_"),
    ("rq/plan_toolpath/_action/cancel_goalRequest", "action_msgs::srv::dds_::CancelGoal_Request_"),
] + [
    ("rq/toolpath_planner/%sRequest" % s, "rcl_interfaces::srv::dds_::%s_Request_" % t_)
    for s, t_ in (("list_parameters", "ListParameters"), ("get_parameters", "GetParameters"),
                  ("set_parameters", "SetParameters"), ("set_parameters_atomically", "SetParametersAtomically"),
                  ("describe_parameters", "DescribeParameters"), ("get_parameter_types", "GetParameterTypes"))
]


def rss_mb(pid):
    with open("/proc/%d/status" % pid) as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def test_fuzzed_payloads_on_every_endpoint_leave_the_node_serving(node, client):
    from cyclonedds.core import Policy, Qos
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    rng = random.Random(1234)
    dp = client.node._dp
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=5)), Policy.Durability.Volatile,
              Policy.History.KeepLast(100))
    writers = []
    for topic, typename in FUZZED:
        cls = fuzz_type(typename)
        writers.append((topic, DataWriter(dp, Topic(dp, topic, cls), qos=qos), cls))
    deadline = time.monotonic() + 20
    for topic, w, _ in writers:
        while not w.get_matched_subscriptions():
            assert time.monotonic() < deadline, "the node's reader of %s was not discovered" % topic
            time.sleep(0.05)
    before = rss_mb(node.pid)
    sent = 0
    for _ in range(150):
        for topic, w, cls in writers:
            n = rng.choice([0, 1, 3, 8, 17, 64, 301, 4096])
            data = [rng.randrange(256) for _ in range(n)]
            if n and rng.random() < 0.5:
                # Lengths and counts that claim far more than is there.
                data[: min(4, n)] = [0xFF] * min(4, n)
            w.write(cls(data=data))
            sent += 1
        time.sleep(0.005)
    time.sleep(1.0)
    assert node.alive(), node.log()[-2000:]
    client.send_surface(quadratic_surface("after_fuzz", 0, 40, -15, 15, ky=0.01))
    client.send_job(job("after_fuzz", "after_fuzz", "iso_parametric", tool("ball", radius=3.0), scallop=0.1))
    got = client.wait_final(["after_fuzz"], timeout=60)["after_fuzz"]
    assert got.state == msgs.JobStatus.SUCCEEDED, got.message
    print("FIGURE fuzz: %d payloads on %d endpoints; node RSS %.0f MB before, %.0f MB after" % (
        sent, len(FUZZED), before, rss_mb(node.pid)))


CLIENTS, JOBS_EACH = 10, 20


def test_concurrent_clients_with_cancels_each_job_ends_once(node):
    from cyclonedds.core import Policy, Qos
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    String = msgs.struct("String", "std_msgs::msg::dds_::String_", [("data", str, str)])
    clients = [Client(node.domain_id, name="client_%d" % k) for k in range(CLIENTS)]
    rng = random.Random(99)
    try:
        qos = Qos(Policy.Reliability.Reliable(duration(seconds=5)), Policy.Durability.Volatile,
                  Policy.History.KeepLast(100))
        cancels = [DataWriter(c.node._dp, Topic(c.node._dp, "rt/cancel", String), qos=qos) for c in clients]
        for c in clients:
            c.wait_for_node()
        clients[0].send_surface(quadratic_surface("many_clients", 0, 40, -15, 15, ky=0.01))
        time.sleep(0.5)
        ids = {}
        for r in range(JOBS_EACH):
            for k, c in enumerate(clients):
                j = "c%02d_j%02d" % (k, r)
                ids.setdefault(k, []).append(j)
                c.send_job(job(j, "many_clients", "iso_parametric", tool("ball", radius=3.0), scallop=0.1))
                if rng.random() < 0.15:
                    cancels[k].write(String(data=j))
        started = time.monotonic()
        for k, c in enumerate(clients):
            c.wait_final(ids[k], timeout=max(10.0, 120 - (time.monotonic() - started)))
        for c in clients:
            c.node.spin_until(lambda: False, 0.1)
        states = {}
        for k, c in enumerate(clients):
            for j in ids[k]:
                finals = faults.distinct_finals(c.statuses[j])
                assert len(finals) == 1, (j, [(s.state, s.message) for s in finals])
                states[finals[0].state] = states.get(finals[0].state, 0) + 1
        assert sum(states.values()) == CLIENTS * JOBS_EACH
        assert set(states) <= {msgs.JobStatus.SUCCEEDED, msgs.JobStatus.CANCELED, msgs.JobStatus.FAILED}, states
        print("FIGURE concurrency: %d clients x %d jobs, finals by state %s in %.1f s" % (
            CLIENTS, JOBS_EACH, states, time.monotonic() - started))
    finally:
        for c in clients:
            c.close()
