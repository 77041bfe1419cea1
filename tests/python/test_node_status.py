"""The node answers job_status on loopback: statuses, reasons, no lost jobs."""

import time

from harness import msgs
from harness.client import Client, job, quadratic_surface, tool
from harness.process import NodeProcess


def test_ready_line_names_domain_and_loopback(node):
    assert "domain %d" % node.domain_id in node.ready_line
    assert "127.0.0.1" in node.ready_line


def test_unknown_strategy_is_rejected_with_the_cli_reason(client, node):
    client.send_job(job("bad_strategy", "s", "spiral", tool("ball", radius=3.0)))
    final = client.wait_final(["bad_strategy"])["bad_strategy"]
    assert final.state == msgs.JobStatus.REJECTED
    assert final.message.startswith('invalid input: strategy: unknown strategy "spiral": expected one of')
    assert "tensor_regions" in final.message
    assert len(client.final("bad_strategy")) == 1
    assert node.alive()


def test_bad_tool_and_machine_are_rejected(client, node):
    client.send_job(job("neg_radius", "s", "iso_scallop", tool("ball", radius=-1.0)))
    client.send_job(job("belt_on_mill", "s", "iso_scallop", tool("ball", radius=3.0), machine="belt6"))
    client.send_job(job("nan_scallop", "s", "iso_scallop", tool("ball", radius=3.0), scallop=float("nan")))
    client.send_job(job("too_fast", "s", "iso_scallop", tool("ball", radius=3.0), scallop=0.05, feed_rate=5000.0))
    got = client.wait_final(["neg_radius", "belt_on_mill", "nan_scallop", "too_fast"])
    assert got["neg_radius"].message == "invalid input: tool.radius: must be positive, got -1"
    assert "machine belt6 cannot carry a ball tool" in got["belt_on_mill"].message
    assert got["nan_scallop"].message == "invalid input: scallop: NaN is not a finite number"
    assert "5000 mm/min exceeds mill5's maximum feed rate 4000 mm/min" in got["too_fast"].message
    assert all(s.state == msgs.JobStatus.REJECTED for s in got.values())
    assert node.alive()


def test_bad_surfaces_reject_their_jobs(client, node):
    s = quadratic_surface("nan_surface", 0, 100, -40, 40, ky=0.01)
    s.control_points[4].z = float("nan")
    client.send_surface(s)
    s = quadratic_surface("short_surface", 0, 100, -40, 40, ky=0.01)
    s.control_points.pop()
    client.send_surface(s)
    client.send_job(job("on_nan", "nan_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
    client.send_job(job("on_short", "short_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
    got = client.wait_final(["on_nan", "on_short"])
    assert got["on_nan"].state == msgs.JobStatus.REJECTED
    assert got["on_nan"].message == (
        'invalid input: surface "nan_surface".control_points[1][1]: has a coordinate that is not a finite number'
    )
    assert got["on_short"].state == msgs.JobStatus.REJECTED
    assert "has 8 points, but count_u x count_v = 3 x 3 needs 9" in got["on_short"].message
    # Both were accepted first (the job itself was fine).
    for j in ("on_nan", "on_short"):
        assert client.statuses[j][0].state == msgs.JobStatus.ACCEPTED
    assert node.alive()


def test_pocket_strategy_on_a_surface_is_rejected(client):
    client.send_surface(quadratic_surface("trough_for_pocket", 0, 100, -40, 40, ky=0.01))
    client.send_job(job("pocket_on_surface", "trough_for_pocket", "pocket_mat", tool("flat_end", radius=5.0)))
    got = client.wait_final(["pocket_on_surface"])["pocket_on_surface"]
    assert got.state == msgs.JobStatus.REJECTED
    assert 'surface_id: "trough_for_pocket": strategy pocket_mat needs a pocket' in got.message


def test_job_waits_for_a_late_surface_then_times_out_without_one():
    proc = NodeProcess(config_text="node:\n  surface_timeout_s: 2.0\n")
    c = Client(proc.domain_id)
    try:
        c.wait_for_node()
        c.send_job(job("early", "late_surface", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
        c.send_job(job("orphan", "never_sent", "iso_scallop", tool("ball", radius=3.0), scallop=0.05))
        c.node.spin_until(lambda: "early" in c.statuses and "orphan" in c.statuses, 10)
        time.sleep(0.5)
        c.send_surface(quadratic_surface("late_surface", 0, 60, -30, 30, ky=0.01))
        t0 = time.monotonic()
        got = c.wait_final(["early", "orphan"], timeout=120)
        # The late surface was used: whatever the planner says, it is not the timeout.
        assert "has not arrived" not in got["early"].message
        assert got["orphan"].state == msgs.JobStatus.FAILED
        assert got["orphan"].message == (
            'surface "never_sent" has not arrived within 2 s: publish it on topic surface (or pocket)'
        )
        assert time.monotonic() - t0 < 60
        assert proc.alive()
    finally:
        c.close()
        proc.stop()


def test_burst_of_200_jobs_loses_none(client, node):
    client.send_surface(quadratic_surface("burst_plane", 0, 40, 0, 40))
    ids = ["burst_%03d" % k for k in range(200)]
    for k, j in enumerate(ids):
        if k % 10 == 9:
            # Some bad ones in the mix: rejected at once, still answered.
            client.send_job(job(j, "burst_plane", "iso_parametric", tool("flat_end", radius=-2.0)))
        else:
            client.send_job(job(j, "burst_plane", "iso_parametric", tool("flat_end", radius=5.0),
                                scallop=0.5, lead_angle_deg=5.0, feed_direction="u"))
    got = client.wait_final(ids, timeout=300)
    for k, j in enumerate(ids):
        assert len(client.final(j)) == 1, j
        if k % 10 == 9:
            assert got[j].state == msgs.JobStatus.REJECTED
        else:
            assert client.statuses[j][0].state == msgs.JobStatus.ACCEPTED
            assert got[j].state == msgs.JobStatus.SUCCEEDED, got[j].message
    assert node.alive()
