"""Every strategy, both machines, through the node: toolpaths, tool poses,
joint trajectories (names, limits, monotone time, forward kinematics back to
the toolpath), markers and statuses. Every strategy must succeed."""

import math
import os

import pytest
import yaml

from harness import msgs
from harness.client import job, quadratic_surface, rect_pocket, evaluate, tool
from harness.msgs import ROOT

with open(os.path.join(ROOT, "launch_configs", "default.yaml")) as fh:
    CELL = yaml.safe_load(fh)

SHAPES = {
    # Concave trough, radius 100 across the feed (u along x).
    "trough": quadratic_surface("trough", 0, 60, -30, 30, ky=0.01),
    # The MPEC reference quadric: kf = 0, kc = 1/1198.
    "mpec_quadric": quadratic_surface("mpec_quadric", 0, 150, -75, 75, ky=1.0 / 1198.0),
    # Convex ridge for the belt, straight rulings along x.
    "ridge": quadratic_surface("ridge", 0, 60, -30, 30, ky=-1.0 / 200.0),
    "rect_pocket": rect_pocket("rect_pocket", 100.0, 60.0),
}

CASES = {
    "tensor_regions": dict(shape="trough", tool_msg=tool("flat_end", radius=2.5), scallop=0.05, lead_angle_deg=5.0),
    "iso_scallop": dict(shape="trough", tool_msg=tool("ball", radius=3.0), scallop=0.05),
    "iso_parametric": dict(
        shape="trough", tool_msg=tool("flat_end", radius=2.5), scallop=0.05, lead_angle_deg=5.0, feed_direction="u"
    ),
    "mpec": dict(
        shape="mpec_quadric", tool_msg=tool("torus", radius=31.5, corner_radius=6.0), tolerance=0.01,
        feed_direction="u",
    ),
    "pocket_mat": dict(shape="rect_pocket", tool_msg=tool("flat_end", radius=5.0)),
    "belt_iso_parametric": dict(shape="ridge", tool_msg=tool("belt", radius=50.0, width=10.0), scallop=0.01),
    "belt_iso_planar": dict(shape="ridge", tool_msg=tool("belt", radius=50.0, width=10.0), scallop=0.01),
}
MACHINE = {s: ("belt6" if s.startswith("belt") else "mill5") for s in CASES}
FEED = 1200.0  # mm/min


@pytest.fixture(scope="module")
def results(client):
    """Sends every shape and one job per strategy; collects the final statuses."""
    for s in SHAPES.values():
        if isinstance(s, msgs.Pocket):
            client.send_pocket(s)
        else:
            client.send_surface(s)
    for strategy, case in CASES.items():
        case = dict(case)
        shape = case.pop("shape")
        client.send_job(job("all_" + strategy, shape, strategy, machine=MACHINE[strategy], feed_rate=FEED, **case))
    return client.wait_final(["all_" + s for s in CASES], timeout=900)


def norm(v):
    return math.sqrt(sum(x * x for x in v))


def vec(p):
    return [p.x, p.y, p.z]


def rotate(q, v):
    """Rotates v by the unit quaternion q (geometry_msgs/Quaternion)."""
    w, x, y, z = q.w, q.x, q.y, q.z
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return [sum(r[i][k] * v[k] for k in range(3)) for i in range(3)]


def mill5_fk(q, pivot_length):
    """Tool tip (mm, workpiece frame) and axis of mill5 joints (m, rad)."""
    cfg = CELL["mill5"]
    x, y, z, a, c = q
    axis = [math.sin(a) * math.sin(c), -math.sin(a) * math.cos(c), math.cos(a)]
    o = cfg["workpiece_origin_mm"]
    pivot = [x * 1e3 - o[0], y * 1e3 - o[1], z * 1e3 - o[2]]
    return [pivot[k] - pivot_length * axis[k] for k in range(3)], axis


def belt6_fk(q):
    """Wheel centre (mm), wheel axis and contact normal of belt6 joints."""
    cfg = CELL["belt6"]
    x, y, z, a, b, c = q

    def rx(v, t):
        return [v[0], math.cos(t) * v[1] - math.sin(t) * v[2], math.sin(t) * v[1] + math.cos(t) * v[2]]

    def ry(v, t):
        return [math.cos(t) * v[0] + math.sin(t) * v[2], v[1], -math.sin(t) * v[0] + math.cos(t) * v[2]]

    def rz(v, t):
        return [math.cos(t) * v[0] - math.sin(t) * v[1], math.sin(t) * v[0] + math.cos(t) * v[1], v[2]]

    rot = lambda v: rz(ry(rx(v, a), b), c)  # noqa: E731
    o = cfg["workpiece_origin_mm"]
    return [x * 1e3 - o[0], y * 1e3 - o[1], z * 1e3 - o[2]], rot([1, 0, 0]), rot([0, 0, 1])


def joint_limits(machine):
    cfg = CELL[machine]
    out = []
    for name in ("x", "y", "z", "a", "b", "c"):
        if name not in cfg:
            continue
        j = cfg[name]
        if "min_mm" in j:
            out.append((j["min_mm"] * 1e-3, j["max_mm"] * 1e-3, j["max_velocity_mm_s"] * 1e-3))
        else:
            r = math.radians
            out.append((r(j["min_deg"]), r(j["max_deg"]), r(j["max_velocity_deg_s"])))
    return out


@pytest.mark.parametrize("strategy", sorted(CASES))
def test_strategy_through_the_node(strategy, results, client, node):
    job_id = "all_" + strategy
    final = results[job_id]
    statuses = client.statuses[job_id]
    assert len(client.final(job_id)) == 1, [s.state for s in statuses]
    assert statuses[0].state == msgs.JobStatus.ACCEPTED
    assert final.state == msgs.JobStatus.SUCCEEDED, final.message
    running = [s for s in statuses if s.state == msgs.JobStatus.RUNNING]
    assert running, "no RUNNING status"
    progress = [s.progress for s in running]
    assert progress == sorted(progress) and all(0.0 <= p <= 1.0 for p in progress)
    assert statuses[-1].state == msgs.JobStatus.SUCCEEDED and statuses[-1].progress == 1.0

    tp, poses, (machine, traj), markers = client.outputs(job_id)
    case = CASES[strategy]
    shape = SHAPES[case["shape"]]
    # Toolpath.
    assert (tp.job_id, tp.strategy, tp.machine, tp.surface_id) == (job_id, strategy, MACHINE[strategy], case["shape"])
    assert tp.header.frame_id == "workpiece"
    assert tp.tool.kind == case["tool_msg"].kind
    passes = [p for p in tp.passes if p.points]
    points = [q for p in passes for q in p.points]
    assert passes and len(tp.passes) == tp.stats.passes
    assert len(points) == tp.stats.points
    length = sum(norm([b - a for a, b in zip(vec(p.points[k].cl), vec(p.points[k + 1].cl))])
                 for p in passes for k in range(len(p.points) - 1))
    if strategy != "pocket_mat":
        assert abs(length - tp.stats.path_length_mm) <= 1e-6 * max(1.0, length)
    for q in points:
        assert abs(norm(vec(q.axis)) - 1.0) < 1e-6
        assert q.feed_rate == FEED
        if isinstance(shape, msgs.Surface):
            on = evaluate(shape, q.u, q.v)
            du, dv = shape.degree_u, shape.degree_v
            u0, u1 = shape.knots_u[du], shape.knots_u[-du - 1]
            v0, v1 = shape.knots_v[dv], shape.knots_v[-dv - 1]
            eps_u, eps_v = 1e-9 * (u1 - u0), 1e-9 * (v1 - v0)
            on_edge = (min(abs(q.u - u0), abs(q.u - u1)) <= eps_u
                       or min(abs(q.v - v0), abs(q.v - v1)) <= eps_v)
            # Run-out points past the surface edge keep the edge's (u, v) and continue the
            # surface by up to about two tool radii (planners extend passes so the whole
            # tool clears the edge); every other cc lies on the surface.
            limit = 2.4 * tp.tool.radius + 1e-3 if on_edge else 1e-3
            assert norm([a - b for a, b in zip(on, vec(q.cc))]) < limit, (q.u, q.v, on, vec(q.cc))
    # Tool poses: one per point, at cl (metres), z (mill) / x (belt) along the axis.
    assert len(poses.poses) == len(points)
    for pose, q in zip(poses.poses, points):
        assert norm([a * 1e3 - b for a, b in zip(vec(pose.position), vec(q.cl))]) < 1e-9
        o = pose.orientation
        assert abs(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w - 1.0) < 1e-9
        axis = [a / norm(vec(q.axis)) for a in vec(q.axis)]
        body = [0, 0, 1] if machine == "mill5" else [1, 0, 0]
        assert norm([a - b for a, b in zip(rotate(o, body), axis)]) < 1e-6
    # Joint trajectory.
    assert machine == MACHINE[strategy]
    names = ["X", "Y", "Z", "A", "C"] if machine == "mill5" else ["X", "Y", "Z", "A", "B", "C"]
    assert traj.joint_names == names
    assert len(traj.points) == len(points) + 2 * len(passes)
    times = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in traj.points]
    # JTC: a zero stamp starts on receipt; the first point (the first approach)
    # comes after the move from the machine's pose, never at 0.
    assert (traj.header.stamp.sec, traj.header.stamp.nanosec) == (0, 0)
    assert times[0] > 0.0 and all(b > a for a, b in zip(times, times[1:]))
    assert all(v == 0.0 for v in traj.points[-1].velocities)
    assert abs(times[-1] - tp.stats.trajectory_duration_s) < 1e-6
    limits = joint_limits(machine)
    for p in traj.points:
        assert len(p.positions) == len(names) and len(p.velocities) == len(names)
        for (lo, hi, vmax), x, v in zip(limits, p.positions, p.velocities):
            assert lo - 1e-9 <= x <= hi + 1e-9
            assert abs(v) <= vmax * (1 + 1e-9)
    # Forward kinematics of the cutting waypoints give back the toolpath.
    k = 0
    tool_length = case["tool_msg"].length or 8.0 * case["tool_msg"].radius
    for p in passes:
        start = k + 1  # after the approach waypoint
        for i, q in enumerate(p.points):
            jp = traj.points[start + i].positions
            axis = [a / norm(vec(q.axis)) for a in vec(q.axis)]
            if machine == "mill5":
                tip, ax = mill5_fk(jp, CELL["mill5"]["pivot_length_mm"] + tool_length)
            else:
                tip, ax, _ = belt6_fk(jp)
            assert norm([a - b for a, b in zip(tip, vec(q.cl))]) < 1e-6, (tip, vec(q.cl))
            assert norm([a - b for a, b in zip(ax, axis)]) < 1e-9
            if i > 0:
                # Cutting moves never exceed the feed (times are whole
                # nanoseconds: each difference may be off by up to 1 ns).
                d = norm([a - b for a, b in zip(vec(q.cl), vec(p.points[i - 1].cl))])
                dt = times[start + i] - times[start + i - 1] + 1e-9
                assert d / dt <= FEED / 60.0 * (1 + 1e-6)
        k = start + len(p.points) + 1  # past the retract waypoint
    assert k == len(traj.points)
    # Markers: clear, then one line strip per pass.
    assert markers.markers[0].action == 3
    strips = [m for m in markers.markers if m.ns == "passes"]
    assert len(strips) == len(passes)
    assert all(m.type == 4 and len(m.points) == len(p.points) for m, p in zip(strips, passes))
    assert node.alive()


def test_tool_too_long_for_the_z_travel_fails_with_the_joint(client, node, results):
    # iso_parametric on the trough with a 2 m long cutter: the pivot would sit above Z's 1500 mm.
    client.send_job(job("too_long", "trough", "iso_parametric", tool("flat_end", radius=2.5, length=2000.0),
                        scallop=0.05, lead_angle_deg=5.0, feed_direction="u"))
    got = client.wait_final(["too_long"], timeout=300)["too_long"]
    assert got.state == msgs.JobStatus.FAILED
    assert "mill5: the approach to pass 0 needs joint Z = " in got.message
    assert "outside its range 0..1500 mm" in got.message
    assert node.alive()


def test_tool_too_large_for_the_pocket_is_answered_with_a_reason(client, node, results):
    client.send_job(job("huge_cutter", "rect_pocket", "pocket_mat", tool("flat_end", radius=45.0)))
    got = client.wait_final(["huge_cutter"], timeout=300)["huge_cutter"]
    assert got.state in (msgs.JobStatus.FAILED, msgs.JobStatus.REJECTED, msgs.JobStatus.SUCCEEDED)
    if got.state != msgs.JobStatus.SUCCEEDED:
        assert got.message and "internal error" not in got.message
    # The node keeps serving after it.
    client.send_job(job("after_huge", "trough", "spiral", tool("ball", radius=1.0)))
    assert client.wait_final(["after_huge"])["after_huge"].state == msgs.JobStatus.REJECTED
    assert node.alive()
