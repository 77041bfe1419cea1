"""A test client of the node: publishes shapes and jobs, collects every output.

All outputs of one job carry the same header stamp, so poses and markers are
matched to their Toolpath (which names the job) by stamp. A trajectory's stamp
is its start time for the controller (zero by default), so it is matched by its
machine and its duration (the Toolpath's stats.trajectory_duration_s).
"""

import math

from . import msgs
from .ros import QOS_JOB, QOS_READ_ALL, QOS_SHAPES, QoSProfile, Node

FINAL = (msgs.JobStatus.SUCCEEDED, msgs.JobStatus.FAILED, msgs.JobStatus.REJECTED)
STATE_NAMES = {0: "ACCEPTED", 1: "RUNNING", 2: "SUCCEEDED", 3: "FAILED", 4: "REJECTED"}


def stamp_key(header):
    return (header.stamp.sec, header.stamp.nanosec)


class Client:
    def __init__(self, domain_id, namespace="/", name="toolpath_test_client"):
        self.node = Node(name, namespace=namespace, domain_id=domain_id)
        n = self.node
        self.surface_pub = n.create_publisher(msgs.Surface, "surface", QOS_SHAPES)
        self.pocket_pub = n.create_publisher(msgs.Pocket, "pocket", QOS_SHAPES)
        # Keep every job until acknowledged: the test's writer must not drop any.
        self.job_pub = n.create_publisher(msgs.Job, "job", QoSProfile(keep_all=True))
        self.statuses = {}
        self.toolpaths = {}
        self.poses = {}
        self.trajectories = []
        self.markers = {}
        n.create_subscription(msgs.JobStatus, "job_status", self._on_status, QOS_READ_ALL)
        n.create_subscription(msgs.Toolpath, "toolpath", self._on_toolpath, QOS_READ_ALL)
        n.create_subscription(msgs.PoseArray, "tool_poses", self._on_poses, QOS_READ_ALL)
        n.create_subscription(
            msgs.JointTrajectory, "mill5/joint_trajectory", lambda m: self._on_traj("mill5", m), QOS_READ_ALL
        )
        n.create_subscription(
            msgs.JointTrajectory, "belt6/joint_trajectory", lambda m: self._on_traj("belt6", m), QOS_READ_ALL
        )
        n.create_subscription(msgs.MarkerArray, "markers", self._on_markers, QOS_READ_ALL)
        self._subs_matched = False

    # -- callbacks ---------------------------------------------------------------
    def _on_status(self, m):
        self.statuses.setdefault(m.job_id, []).append(m)

    def _on_toolpath(self, m):
        self.toolpaths[m.job_id] = m

    def _on_poses(self, m):
        self.poses[stamp_key(m.header)] = m

    def _on_traj(self, machine, m):
        self.trajectories.append((machine, m))

    def _trajectory_of(self, tp):
        """The trajectory published with toolpath `tp`: same stamp, or a start
        stamp (zero or later) and the toolpath's duration to the microsecond."""
        for machine, m in self.trajectories:
            if machine != tp.machine:
                continue
            if stamp_key(m.header) == stamp_key(tp.header):
                return machine, m
            last = m.points[-1].time_from_start if m.points else None
            duration = last.sec + last.nanosec * 1e-9 if last else 0.0
            starts = stamp_key(m.header) == (0, 0) or stamp_key(m.header) >= stamp_key(tp.header)
            if starts and abs(duration - tp.stats.trajectory_duration_s) < 1e-6:
                return machine, m
        return None

    def _on_markers(self, m):
        if m.markers:
            self.markers[stamp_key(m.markers[0].header)] = m

    # -- sending -----------------------------------------------------------------
    def wait_for_node(self, timeout=20.0):
        """Waits until the node's job reader and status writer are matched."""
        ok = self.node.spin_until(lambda: self.job_pub.get_subscription_count() > 0, timeout)
        assert ok, "the node's job subscription was not discovered within %s s" % timeout

    def send_surface(self, surface):
        self.surface_pub.publish(surface)

    def send_pocket(self, pocket):
        self.pocket_pub.publish(pocket)

    def send_job(self, job):
        self.job_pub.publish(job)

    # -- waiting -----------------------------------------------------------------
    def final(self, job_id):
        """The final statuses of a job (a correct node gives exactly one)."""
        return [s for s in self.statuses.get(job_id, []) if s.state in FINAL]

    def wait_final(self, job_ids, timeout=60.0):
        ids = list(job_ids)
        self.node.spin_until(lambda: all(self.final(j) for j in ids), timeout)
        # A little longer, to catch duplicate final statuses.
        self.node.spin_until(lambda: False, 0.2)
        missing = [j for j in ids if not self.final(j)]
        assert not missing, "no final status for %d jobs, e.g. %s" % (len(missing), missing[:5])
        return {j: self.final(j)[-1] for j in ids}

    def outputs(self, job_id, timeout=20.0):
        """(toolpath, poses, (machine, trajectory), markers) of a succeeded job."""

        def have():
            tp = self.toolpaths.get(job_id)
            if tp is None:
                return False
            k = stamp_key(tp.header)
            return k in self.poses and self._trajectory_of(tp) is not None and k in self.markers

        assert self.node.spin_until(have, timeout), "outputs of %s incomplete" % job_id
        tp = self.toolpaths[job_id]
        k = stamp_key(tp.header)
        return tp, self.poses[k], self._trajectory_of(tp), self.markers[k]

    def close(self):
        self.node.destroy_node()


# -- message builders ---------------------------------------------------------------
def header(frame="workpiece"):
    return msgs.Header(frame_id=frame)


def bezier_surface(surface_id, xs, ys, zgrid):
    """A tensor-product Bezier patch (clamped knots) with control points at
    (xs[i], ys[j], zgrid[i][j])."""
    du, dv = len(xs) - 1, len(ys) - 1
    pts = [msgs.Point(x=float(xs[i]), y=float(ys[j]), z=float(zgrid[i][j])) for i in range(du + 1) for j in range(dv + 1)]
    return msgs.Surface(
        header=header(),
        surface_id=surface_id,
        degree_u=du,
        degree_v=dv,
        knots_u=[0.0] * (du + 1) + [1.0] * (du + 1),
        knots_v=[0.0] * (dv + 1) + [1.0] * (dv + 1),
        count_u=du + 1,
        count_v=dv + 1,
        control_points=pts,
        weights=[],
    )


def quadratic_surface(surface_id, x0, x1, y0, y1, kx=0.0, ky=0.0):
    """z = kx x^2 / 2 + ky y^2 / 2 on [x0,x1] x [y0,y1], exact as a biquadratic
    Bezier patch (control z of a parabola: ends on it, middle where the end
    tangents meet)."""

    def ctrl(a, b, k):
        f = lambda t: 0.5 * k * t * t  # noqa: E731
        m = 0.5 * (a + b)
        # Tangent intersection at the midpoint parameter: f(a) + f'(a)(m - a).
        return [f(a), f(a) + k * a * (m - a), f(b)]

    xs = [x0, 0.5 * (x0 + x1), x1]
    ys = [y0, 0.5 * (y0 + y1), y1]
    cx, cy = ctrl(x0, x1, kx), ctrl(y0, y1, ky)
    return bezier_surface(surface_id, xs, ys, [[cx[i] + cy[j] for j in range(3)] for i in range(3)])


def evaluate(surface, u, v):
    """Point of a single-span (Bezier) surface message at (u, v) in [0,1]^2."""
    du, dv, nv = surface.degree_u, surface.degree_v, surface.count_v

    def bern(n, t):
        return [math.comb(n, i) * t**i * (1 - t) ** (n - i) for i in range(n + 1)]

    bu, bv = bern(du, u), bern(dv, v)
    out = [0.0, 0.0, 0.0]
    for i in range(du + 1):
        for j in range(dv + 1):
            p = surface.control_points[i * nv + j]
            w = bu[i] * bv[j]
            out[0] += w * p.x
            out[1] += w * p.y
            out[2] += w * p.z
    return out


def rect_pocket(pocket_id, w, h):
    corners = [(0, 0), (w, 0), (w, h), (0, h)]
    return msgs.Pocket(
        header=header(),
        pocket_id=pocket_id,
        outer=msgs.PocketLoop(points=[msgs.Point(x=float(x), y=float(y), z=0.0) for x, y in corners]),
        holes=[],
    )


def tool(kind, radius=0.0, corner_radius=0.0, width=0.0, length=0.0):
    return msgs.Tool(kind=kind, radius=radius, corner_radius=corner_radius, width=width, length=length)


def job(job_id, surface_id, strategy, tool_msg, machine="", scallop=0.0, tolerance=0.0, lead_angle_deg=0.0,
        feed_rate=0.0, feed_direction=""):
    return msgs.Job(
        header=header(),
        job_id=job_id,
        surface_id=surface_id,
        machine=machine,
        strategy=strategy,
        tool=tool_msg,
        scallop=scallop,
        tolerance=tolerance,
        lead_angle_deg=lead_angle_deg,
        feed_rate=feed_rate,
        feed_direction=feed_direction,
    )
