"""The PlanToolpath action and service of the node, driven from a Cyclone DDS
peer on loopback as rmw_cyclonedds lays them out (harness/action.py): a goal
with feedback and its toolpath, the service answering as the action, a goal
canceled while it plans, a bad goal and a cancel of an unknown goal refused
with their reasons while the node keeps serving."""

import time

import pytest

from harness import action, msgs
from harness.client import job, quadratic_surface, tool
from harness.process import NodeProcess
from harness.ros import Node

NS = "/cell_a"


@pytest.fixture(scope="module")
def cell():
    proc = NodeProcess(ros_args=["-r", "__ns:=" + NS, "-p", "node.workers:=1", "-p", "node.verify:=false"])
    peer = None
    try:
        peer = Node("action_test", namespace=NS, domain_id=proc.domain_id)
        client = action.ActionClient(peer._dp, NS)
        client.wait()
        service = action.PlanClient(peer._dp, NS)
        service.wait()
        yield {"proc": proc, "action": client, "service": service}
    finally:
        if peer is not None:
            peer.destroy_node()
        proc.stop()


def goal(job_id, surface, strategy="iso_parametric", **kw):
    """A goal planning `surface` (sent inline) with a flat end R 2.5."""
    j = job(job_id, surface.surface_id, strategy, tool("flat_end", radius=2.5), scallop=kw.pop("scallop", 0.5),
            lead_angle_deg=5.0, feed_direction="u")
    return action.Goal(job=j, surface=[surface])


def points(toolpath):
    return [[(p.cc.x, p.cc.y, p.cc.z) for p in pss.points] for pss in toolpath.passes]


def test_a_goal_reports_feedback_and_ends_with_its_toolpath(cell):
    client = cell["action"]
    surface = quadratic_surface("goal_trough", 0, 40, -20, 20, ky=0.01)
    goal_id, accepted = client.send(goal("py_goal", surface))
    assert accepted
    status, r = client.result(goal_id)
    assert status == action.STATUS_SUCCEEDED, r.reason
    assert r.status == action.Result.SUCCEEDED
    assert r.toolpath.job_id == "py_goal"
    assert not r.toolpath_omitted and r.toolpath_topic == NS + "/toolpath"
    assert r.stats.passes == len(r.toolpath.passes) >= 2
    assert r.stats.points == sum(len(p) for p in points(r.toolpath))
    # Feedback of this goal arrived before its result: stages and progress 0..1.
    time.sleep(0.2)
    fb = cell["action"].feedback_of(goal_id)
    stages = {s for s, _ in fb}
    assert {"queued", "planning"} <= stages, fb
    assert all(0.0 <= p <= 1.0 for _, p in fb), fb


def test_the_service_answers_as_the_action(cell):
    surface = quadratic_surface("service_trough", 0, 40, -20, 20, ky=0.01)
    g = goal("py_by_action", surface)
    goal_id, accepted = cell["action"].send(g)
    assert accepted
    _, by_action = cell["action"].result(goal_id)
    req = goal("py_by_service", surface)
    r = cell["service"].call(action.Request(job=req.job, surface=req.surface))
    assert r.status == action.Response.SUCCEEDED, r.reason
    assert r.toolpath.job_id == "py_by_service"
    assert points(r.toolpath) == points(by_action.toolpath)


def test_a_goal_canceled_while_it_plans_ends_canceled_and_the_node_serves_on(cell):
    client = cell["action"]
    # Large and fine enough to plan for a while on one worker.
    big = quadratic_surface("big_bowl", -150, 150, -150, 150, kx=0.004, ky=0.004)
    goal_id, accepted = client.send(goal("py_cancel", big, strategy="iso_scallop", scallop=0.002))
    assert accepted
    deadline = time.monotonic() + 60
    while not any(s == "planning" for s, _ in client.feedback_of(goal_id)):
        assert time.monotonic() < deadline, "no planning feedback"
        time.sleep(0.02)
    r = client.cancel(goal_id)
    assert r.return_code == action.CANCEL_NONE, r
    assert [list(g.goal_id.uuid) for g in r.goals_canceling] == [list(goal_id.uuid)]
    status, res = client.result(goal_id, timeout=30)
    assert status == action.STATUS_CANCELED, res.reason
    assert res.status == action.Result.CANCELED
    assert "cancel" in res.reason, res.reason
    # The worker is free again: a small goal plans.
    small = quadratic_surface("after_cancel", 0, 40, -20, 20)
    goal_id, accepted = client.send(goal("py_after_cancel", small))
    status, res = client.result(goal_id)
    assert status == action.STATUS_SUCCEEDED, res.reason


def test_a_bad_goal_and_an_unknown_cancel_are_refused_with_reasons(cell):
    client = cell["action"]
    surface = quadratic_surface("bad_goal_trough", 0, 40, -20, 20)
    g = goal("py_bad", surface)
    g.job.strategy = "spiral"
    goal_id, accepted = client.send(g)
    assert accepted, "a bad goal is accepted and ends at once with the reason"
    status, r = client.result(goal_id, timeout=30)
    assert status == action.STATUS_ABORTED
    assert r.status == action.Result.REJECTED
    assert "spiral" in r.reason, r.reason
    # An execute value outside 0..2.
    g = goal("py_bad_execute", surface)
    g.job.execute = 9
    goal_id, _ = client.send(g)
    status, r = client.result(goal_id, timeout=30)
    assert r.status == action.Result.REJECTED
    assert r.reason == "invalid input: execute: 9 is not 0 (the machine's default), 1 (execute) or 2 (plan only)"
    r = client.cancel(action.new_goal_id())
    assert r.return_code == action.CANCEL_REJECTED and not r.goals_canceling, r
    # Still serving.
    goal_id, _ = client.send(goal("py_after_bad", surface))
    status, r = client.result(goal_id)
    assert status == action.STATUS_SUCCEEDED, r.reason
