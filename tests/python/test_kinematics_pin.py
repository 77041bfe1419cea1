"""The kinematics crate's joints checked with an independent forward
kinematics: pinocchio (`pin`) on real URDFs from `example-robot-data`
(UR3/UR5/UR10, Franka Panda, Kinova Jaco 2, Unitree Z1, UFactory xArm 7), and on the
repository's own machine URDFs.

Seeded random passes (smooth joint curves, clear of singularities, mapped
to tool poses by pinocchio) go through the crate's `ik_json` example; every
returned joint vector must reproduce its pose within 0.01 mm and 0.01 deg by
pinocchio's FK, lie within the URDF's limits, and no pass may change
configuration (bounded joint steps; for the 6R arms the elbow and wrist
signs stay). A pass out of reach and a pass through a wrist singularity
must be reported at their pass and point.

The URDF text is copied out of example-robot-data into a temporary
directory (meshes are not needed: buildModelFromUrdf reads kinematics only).
"""

import json
import math
import os
import pathlib
import subprocess

from importlib import metadata

import numpy as np
import pinocchio as pin
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
CRATE = REPO / "crates" / "kinematics"
POS_TOL_MM = 0.01
ROT_TOL_DEG = 0.01


def robots_dir():
    """example-robot-data's robots folder (the wheel installs data only, under
    its cmeel prefix's share/example-robot-data/robots)."""
    dist = metadata.distribution("example-robot-data")
    for f in dist.files or []:
        parts = pathlib.PurePath(f).parts
        if "robots" in parts and "example-robot-data" in parts:
            i = parts.index("robots")
            return pathlib.Path(dist.locate_file(pathlib.PurePath(*parts[: i + 1])))
    raise RuntimeError("example-robot-data is installed without its robots folder")


@pytest.fixture(scope="session")
def ik_json():
    """The crate's ik_json example, built in release (or $IK_JSON_BIN)."""
    if os.environ.get("IK_JSON_BIN"):
        return os.environ["IK_JSON_BIN"]
    manifest = str(CRATE / "Cargo.toml")
    subprocess.run(
        ["cargo", "build", "--release", "--example", "ik_json", "--manifest-path", manifest],
        check=True,
    )
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps", "--manifest-path", manifest],
        check=True,
        capture_output=True,
        text=True,
    )
    target = pathlib.Path(json.loads(meta.stdout)["target_directory"])
    return str(target / "release" / "examples" / "ik_json")


# name, URDF path inside example-robot-data, base link, tool link
ARMS = [
    ("ur3", "ur_description/urdf/ur3_robot.urdf", "base_link", "tool0"),
    ("ur5", "ur_description/urdf/ur5_robot.urdf", "base_link", "tool0"),
    ("ur10", "ur_description/urdf/ur10_robot.urdf", "base_link", "tool0"),
    ("panda", "panda_description/urdf/panda.urdf", "panda_link0", "panda_hand_tcp"),
    ("kinova", "kinova_description/robots/kinova.urdf", "j2s6s200_link_base", "j2s6s200_end_effector"),
    ("z1", "z1_description/urdf/z1.urdf", "link00", "link06"),
    ("xarm7", "xarm_description/urdf/xarm7.urdf", "link_base", "link_eef"),
]


class Arm:
    """A pinocchio model of one URDF; joint values in the crate's units (mm, rad)."""

    def __init__(self, path, base, tool, part=None):
        self.path = str(path)
        self.model = pin.buildModelFromUrdf(self.path)
        self.data = self.model.createData()
        self.base = self.model.getFrameId(base)
        self.tool = self.model.getFrameId(tool)
        self.part = self.model.getFrameId(part or base)
        assert max(self.base, self.tool, self.part) < len(self.model.frames)
        # The joints between the base and the tool or the part.
        support = lambda f: set(self.model.supports[self.model.frames[f].parentJoint])
        moving = (support(self.tool) | support(self.part)) - support(self.base)
        self.names = [self.model.names[j] for j in sorted(moving) if j > 0]

    def joint(self, name):
        return self.model.joints[self.model.getJointId(name)]

    def scale(self, name):
        """Crate units per pinocchio unit: mm per m for a slide, 1 for a rotary joint."""
        return 1000.0 if self.joint(name).shortname().startswith("JointModelP") else 1.0

    def limits(self, name):
        jm = self.joint(name)
        if jm.nq == 2:  # continuous: unbounded
            return -math.inf, math.inf
        i, k = jm.idx_q, self.scale(name)
        return self.model.lowerPositionLimit[i] * k, self.model.upperPositionLimit[i] * k

    def q(self, joints, names):
        q = pin.neutral(self.model)
        for name, v in zip(names, joints):
            jm = self.joint(name)
            if jm.nq == 2:
                q[jm.idx_q], q[jm.idx_q + 1] = math.cos(v), math.sin(v)
            else:
                q[jm.idx_q] = v / self.scale(name)
        return q

    def pose(self, joints, names):
        """The tool frame in the part frame (mm), by pinocchio."""
        q = self.q(joints, names)
        pin.framesForwardKinematics(self.model, self.data, q)
        m = self.data.oMf[self.part].inverse() * self.data.oMf[self.tool]
        return m.translation * 1000.0, m.rotation

    def conditioning(self, joints, names):
        """Smallest over largest singular value of the 6-D Jacobian (rotation rows at 500 mm)."""
        q = self.q(joints, names)
        j = pin.computeFrameJacobian(self.model, self.data, q, self.tool, pin.LOCAL_WORLD_ALIGNED)
        cols = [self.model.joints[self.model.getJointId(n)].idx_v for n in names]
        jj = j[:, cols].copy()
        jj[:3] *= 1000.0
        jj[3:] *= 500.0
        s = np.linalg.svd(jj, compute_uv=False)
        return s[min(5, len(names) - 1)] / s[0]


def urdf_copy(tmp_path, rel):
    src = robots_dir() / rel
    dst = tmp_path / pathlib.Path(rel).name
    dst.write_text(src.read_text())
    return dst


def quat_xyzw(r):
    q = pin.Quaternion(r)
    return [q.x, q.y, q.z, q.w]


def joint_curve(arm, rng, names, n, amp, clear=0.05):
    """A smooth joint curve inside the limits, clear of singularities (an
    arm's Jacobian conditioning above `clear`; 0 = no check); None if not."""
    lims = [arm.limits(nm) for nm in names]
    q0 = []
    for lo, hi in lims:
        if not math.isfinite(lo):
            lo, hi = -math.pi, math.pi
        q0.append(rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo)))
    a = rng.uniform(-amp, amp, len(names)) * np.array([arm.scale(n) for n in names])
    ph = rng.uniform(0, 2 * math.pi, len(names))
    rows = [[q0[j] + a[j] * math.sin(math.pi * k / (n - 1) + ph[j]) for j in range(len(names))] for k in range(n)]
    for r in rows:
        if any(not (lo + 0.05 * arm.scale(n) <= v <= hi - 0.05 * arm.scale(n)) for v, (lo, hi), n in zip(r, lims, names)):
            return None
        if clear > 0 and arm.conditioning(r, names) < clear:
            return None
    return rows


def solve(ik_json, tmp_path, request):
    path = tmp_path / "request.json"
    path.write_text(json.dumps(request))
    out = subprocess.run([ik_json, str(path)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def check_pass(arm, names, poses, joints, kind):
    """Every pose reproduced by pinocchio, within limits, no configuration change."""
    assert len(joints) == len(poses)
    for k, (pose, q) in enumerate(zip(poses, joints)):
        p, r = arm.pose(q, names)
        if kind == "axis":
            dp = np.linalg.norm(p - np.array(pose["tip"]))
            axis = -r[:, 2]
            ang = math.degrees(math.atan2(np.linalg.norm(np.cross(axis, pose["axis"])), float(np.dot(axis, pose["axis"]))))
        else:
            dp = np.linalg.norm(p - np.array(pose["xyz_mm"]))
            want = pin.Quaternion(*[pose["quat_xyzw"][i] for i in (3, 0, 1, 2)]).toRotationMatrix()
            ang = math.degrees(np.linalg.norm(pin.log3(want.T @ r)))
        assert dp < POS_TOL_MM and ang < ROT_TOL_DEG, f"point {k}: {dp} mm {ang} deg"
        for name, v in zip(names, q):
            lo, hi = arm.limits(name)
            assert lo - 1e-9 <= v <= hi + 1e-9, f"point {k}: {name} = {v} outside {lo}..{hi}"
    rotary = [j for j, n in enumerate(names) if arm.scale(n) == 1.0]
    steps = np.abs(np.diff(np.array(joints)[:, rotary], axis=0))
    assert steps.max() < 0.2, f"joint step {steps.max()} rad at point {int(steps.max(axis=1).argmax())}"
    if "elbow_joint" in names:
        # A UR arm's elbow and wrist 2 keep their sides: no configuration flip.
        for n in ("elbow_joint", "wrist_2_joint"):
            s = np.sign(np.sin(np.array(joints)[:, names.index(n)]))
            assert (s == s[0]).all(), f"{n} changes side inside the pass"


@pytest.mark.parametrize("name,rel,base,tool", ARMS, ids=[a[0] for a in ARMS])
def test_seeded_passes_reproduce_the_poses_under_pinocchio(ik_json, tmp_path, name, rel, base, tool):
    path = urdf_copy(tmp_path, rel)
    arm = Arm(path, base, tool)
    rng = np.random.default_rng(sum(map(ord, name)))
    curves = []
    while len(curves) < 4:
        c = joint_curve(arm, rng, arm.names, 60, 0.35)
        if c is not None:
            curves.append(c)
    passes, kinds = [], []
    for c in curves:
        poses_axis, poses_frame = [], []
        for q in c:
            p, r = arm.pose(q, arm.names)
            poses_axis.append({"tip": p.tolist(), "axis": (-r[:, 2]).tolist()})
            poses_frame.append({"xyz_mm": p.tolist(), "quat_xyzw": quat_xyzw(r)})
        passes += [poses_axis, poses_frame]
        kinds += ["axis", "frame"]
    answer = solve(ik_json, tmp_path, {"urdf": str(path), "base_link": base, "tool_link": tool, "passes": passes})
    names = answer["joint_names"]
    assert sorted(names) == sorted(arm.names), (names, arm.names)
    for p, (res, poses, kind) in enumerate(zip(answer["passes"], passes, kinds)):
        assert res["ok"], f"{name} pass {p} ({kind}, {answer['solver']}): {res}"
        check_pass(arm, names, poses, res["joints"], kind)


def test_a_pass_out_of_reach_is_reported_at_its_first_unreachable_point(ik_json, tmp_path):
    path = urdf_copy(tmp_path, "ur_description/urdf/ur5_robot.urdf")
    arm = Arm(path, "base_link", "tool0")
    p, r = arm.pose([0.3, -1.2, 1.3, -1.5, -1.4, 0.2], arm.names)
    out = (p * np.array([1.0, 1.0, 0.0])) / np.linalg.norm(p[:2])
    poses = [{"tip": (p + out * 40.0 * k).tolist(), "axis": (-r[:, 2]).tolist()} for k in range(40)]
    answer = solve(ik_json, tmp_path, {"urdf": str(path), "base_link": "base_link", "tool_link": "tool0", "passes": [poses, poses[:3]]})
    bad, good = answer["passes"]
    assert not bad["ok"] and bad["kind"] == "unreachable" and bad["pass"] == 0, bad
    k = bad["point"]
    shoulder = np.array([0.0, 0.0, 89.159])
    # UR5: 425 + 392 mm of arm, wrist offsets aside: the first point it cannot reach is beyond ~800 mm.
    assert np.linalg.norm(np.array(poses[k]["tip"]) - shoulder) > 800.0 and k > 0, bad
    assert good["ok"], good


def test_a_pass_through_a_wrist_singularity_is_reported_there(ik_json, tmp_path):
    path = urdf_copy(tmp_path, "ur_description/urdf/ur5_robot.urdf")
    arm = Arm(path, "base_link", "tool0")
    rows = [[0.4, -1.0, 1.2, 0.3, (k - 20) * 0.01, 0.5] for k in range(41)]
    poses = []
    for q in rows:
        p, r = arm.pose(q, arm.names)
        poses.append({"xyz_mm": p.tolist(), "quat_xyzw": quat_xyzw(r)})
    # Shoulder, upper arm and elbow held near this pose: one arm configuration.
    limits = [{"joint": n, "lower": rows[0][j] - 0.6, "upper": rows[0][j] + 0.6} for j, n in enumerate(arm.names[:3])]
    answer = solve(ik_json, tmp_path, {"urdf": str(path), "base_link": "base_link", "tool_link": "tool0", "limits": limits, "passes": [poses[:10], poses]})
    ok, bad = answer["passes"]
    assert ok["ok"], ok
    check_pass(arm, answer["joint_names"], poses[:10], ok["joints"], "frame")
    assert not bad["ok"] and bad["kind"] == "singular" and bad["pass"] == 1, bad
    assert "wrist" in bad["message"] and abs(rows[bad["point"]][4]) < 0.03, bad


def test_a_robot_holding_the_part_against_a_fixed_belt(ik_json, tmp_path):
    path = urdf_copy(tmp_path, "ur_description/urdf/ur10_robot.urdf")
    arm = Arm(path, "base_link", "tool0")
    part = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.15]))
    flip = pin.SE3(pin.utils.rpyToMatrix(math.pi, 0.0, 0.0), np.zeros(3))
    p0, r0 = arm.pose([0.3, -1.3, 1.6, -1.9, -1.5, 0.2], arm.names)
    belt = pin.SE3(r0, p0 / 1000.0) * part * flip
    poses = [{"tip": [-60.0 + k, 20.0 * math.sin(k * 0.05), 0.0], "axis": [0.1 * math.cos(k * 0.03), 0.0, 1.0]} for k in range(120)]
    rpy = pin.rpy.matrixToRpy(belt.rotation).tolist()
    request = {
        "urdf": str(path), "base_link": "base_link", "tool_link": "tool0", "holds": "part",
        "tcp_xyz_mm": (belt.translation * 1000.0).tolist(), "tcp_rpy": rpy,
        "workpiece_xyz_mm": [0.0, 0.0, 150.0], "workpiece_rpy": [0.0, 0.0, 0.0],
        "passes": [poses],
    }
    answer = solve(ik_json, tmp_path, request)
    res = answer["passes"][0]
    assert res["ok"], res
    for pose, q in zip(poses, res["joints"]):
        p, r = arm.pose(q, answer["joint_names"])
        flange = pin.SE3(r, p / 1000.0)
        contact = (flange * part).inverse() * belt
        axis = -contact.rotation[:, 2]
        want = np.array(pose["axis"]) / np.linalg.norm(pose["axis"])
        assert np.linalg.norm(contact.translation * 1000.0 - pose["tip"]) < POS_TOL_MM
        assert math.degrees(math.acos(min(1.0, float(axis @ want)))) < ROT_TOL_DEG


@pytest.mark.parametrize(
    "urdf,base,tool,part",
    [("trunnion5.urdf", "base_link", "tool0", "table"), ("mill5.urdf", "mill5_base", "tool0", None)],
)
def test_the_repository_machines_under_pinocchio(ik_json, tmp_path, urdf, base, tool, part):
    path = REPO / "launch_configs" / "urdf" / urdf
    arm = Arm(path, base, tool, part)
    assert len(arm.names) == 5
    rng = np.random.default_rng(7)
    curves = []
    while len(curves) < 3:
        c = joint_curve(arm, rng, arm.names, 80, 0.3, clear=0)
        if c is not None:
            curves.append(c)
    passes = []
    for c in curves:
        poses = []
        for q in c:
            p, r = arm.pose(q, arm.names)
            poses.append({"tip": p.tolist(), "axis": (-r[:, 2]).tolist()})
        passes.append(poses)
    request = {"urdf": str(path), "base_link": base, "tool_link": tool, "passes": passes}
    if part:
        request["part_link"] = part
    answer = solve(ik_json, tmp_path, request)
    assert sorted(answer["joint_names"]) == sorted(arm.names)
    for res, poses in zip(answer["passes"], passes):
        assert res["ok"], res
        check_pass(arm, answer["joint_names"], poses, res["joints"], "axis")
