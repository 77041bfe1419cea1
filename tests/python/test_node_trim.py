"""A trimmed surface over ROS: Surface.trim_loops carries the trim as the
file format does, the node plans on the face only (no contact deep inside
the hole), and a bad trim refuses the job naming the field."""

from harness import msgs
from harness.client import job, quadratic_surface, tool


def trimmed_plane(surface_id, hole):
    """The plane z = 0 over [0, 60] x [-30, 30] (u along x), its outer loop
    the domain's edges, with a square hole given as a polyline in (u, v)."""
    s = quadratic_surface(surface_id, 0, 60, -30, 30)
    outer = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 0.0]
    (a, b) = hole
    square = [a, a, a, b, b, b, b, a, a, a]
    s.trim_loops = [
        msgs.TrimLoop(curves=[msgs.TrimCurve(degree=0, points_uv=outer)]),
        msgs.TrimLoop(curves=[msgs.TrimCurve(degree=0, points_uv=square)]),
    ]
    return s


def test_a_trimmed_surface_is_planned_on_its_face(client):
    client.send_surface(trimmed_plane("holed_plane", (0.2, 0.8)))
    client.send_job(job("holed", "holed_plane", "iso_parametric", tool("ball", radius=3.0), scallop=0.05,
                        feed_rate=1000.0, feed_direction="u"))
    final = client.wait_final(["holed"], timeout=300)["holed"]
    assert final.state == msgs.JobStatus.SUCCEEDED, final.message
    tp, _, _, _ = client.outputs("holed")
    points = [p for ps in tp.passes for p in ps.points]
    assert points
    # The hole is x in [12, 48], y in [-18, 18]; run-ins and run-outs reach
    # at most a few tool radii into it.
    deep = [p.cc for p in points if 25 < p.cc.x < 35 and -5 < p.cc.y < 5]
    assert not deep, deep[:3]
    near = [p for p in points if 12 < p.cc.x < 48 and -18 < p.cc.y < 18]
    assert len(near) < 0.2 * len(points)


def test_a_bad_trim_is_refused_naming_the_field(client):
    # A hole outside the outer loop.
    client.send_surface(trimmed_plane("bad_trim", (1.2, 1.4)))
    client.send_job(job("bad_trim_job", "bad_trim", "iso_parametric", tool("ball", radius=3.0), scallop=0.05,
                        feed_rate=1000.0, feed_direction="u"))
    final = client.wait_final(["bad_trim_job"], timeout=60)["bad_trim_job"]
    assert final.state != msgs.JobStatus.SUCCEEDED
    assert "trim_loops" in final.message, final.message
