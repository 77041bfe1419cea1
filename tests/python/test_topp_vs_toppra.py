"""The motion crate's time-optimal parameterisation against the `toppra` package.

Seeded random 6-joint paths (50-500 waypoints), with and without a cap on the
tool tip's speed (the tip is the first three joints, a gantry's linear axes).
Both time the same geometric path: toppra gets the waypoints at the path
parameters the crate chose, splined with the same natural boundary condition.
The tip speed cap is a constraint on x = s_dot^2 at every grid point
(x <= cap^2 / |p'(s)|^2), as the crate applies it.

Checked: our duration <= 1.02 x toppra's, and the trajectory sampled every
1 ms with the joint_trajectory_controller's interpolation (re-implemented
here from its formulas) keeps every joint velocity and acceleration limit and
the tip speed cap.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

toppra = pytest.importorskip("toppra")
from scipy.interpolate import CubicSpline  # noqa: E402
from toppra import constraint as tc  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MANIFEST = ROOT / "crates" / "motion" / "Cargo.toml"

VEL = np.array([400.0, 400.0, 300.0, 2.5, 3.0, 3.5])
ACC = np.array([1500.0, 2000.0, 1200.0, 8.0, 12.0, 15.0])


@pytest.fixture(scope="module")
def topp_json():
    """$MOTION_TOPP_JSON, else the example built by cargo (release)."""
    env = os.environ.get("MOTION_TOPP_JSON")
    if env:
        return env
    out = subprocess.run(
        ["cargo", "build", "--release", "--example", "topp_json",
         "--manifest-path", str(MANIFEST), "--message-format=json"],
        check=True, capture_output=True, text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg["target"]["name"] == "topp_json":
            if msg.get("executable"):
                return msg["executable"]
    raise RuntimeError("cargo built no topp_json example")


def random_path(rng, n):
    """A smooth random joint path: a few harmonics per joint, like a pass."""
    dense = 2 * n
    w = np.linspace(0.0, 1.0, dense)
    q = np.zeros((dense, 6))
    amp = np.array([150.0, 120.0, 40.0, 0.6, 1.2, 0.8])
    for j in range(6):
        for h in range(1, 4):
            q[:, j] += amp[j] / h * np.sin(2 * np.pi * (h * rng.uniform(0.3, 1.5) * w + rng.uniform()))
    # Uneven spacing, as a planner's points are.
    inner = rng.choice(np.arange(1, dense - 1), size=n - 2, replace=False)
    keep = np.sort(np.concatenate(([0, dense - 1], inner)))
    return q[keep]


class TipSpeed(tc.LinearConstraint):
    """|p'(s)| s_dot <= cap, p = the first three joints: x <= cap^2 / |p'|^2."""

    def __init__(self, cap):
        super().__init__()
        self.cap = cap
        self.dof = 6

    def compute_constraint_params(self, path, gridpoints):
        dp = path(gridpoints, 1)[:, :3]
        rate2 = np.maximum(np.sum(dp * dp, axis=1), 1e-300)
        xbound = np.zeros((len(gridpoints), 2))
        xbound[:, 1] = self.cap ** 2 / rate2
        return None, None, None, None, None, None, xbound


def toppra_duration(s, q, cap):
    path = toppra.SplineInterpolator(s, q, bc_type="natural")
    cons = [tc.JointVelocityConstraint(VEL), tc.JointAccelerationConstraint(ACC)]
    if cap is not None:
        cons.append(TipSpeed(cap))
    # A grid through every waypoint, each interval split in four (a coarse
    # grid can leave toppra "not controllable").
    grid = np.unique(np.concatenate([np.linspace(a, b, 5) for a, b in zip(s[:-1], s[1:])]))
    for _ in range(3):
        algo = toppra.algorithm.TOPPRA(cons, path, gridpoints=grid, solver_wrapper="seidel")
        _, sd, _ = algo.compute_parameterization(0.0, 0.0)
        if sd is not None and not np.isnan(sd).any():
            ds = np.diff(grid)
            return float(np.sum(2.0 * ds / (sd[:-1] + sd[1:])))
        grid = np.unique(np.concatenate([grid, 0.5 * (grid[:-1] + grid[1:])]))
    raise RuntimeError("toppra found the path not controllable")


def jtc_sample(times, pos, vel, acc, period=1e-3):
    """Velocity and acceleration of JTC's interpolation every `period` s."""
    t = np.arange(0.0, times[-1], period)
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = (times[k + 1] - times[k])[:, None]
    tau = (t - times[k])[:, None]
    p0, p1, v0, v1 = pos[k], pos[k + 1], vel[k], vel[k + 1]
    if acc is None:
        c2 = (-3 * p0 + 3 * p1 - 2 * v0 * h - v1 * h) / h**2
        c3 = (2 * p0 - 2 * p1 + v0 * h + v1 * h) / h**3
        v = v0 + 2 * c2 * tau + 3 * c3 * tau**2
        a = 2 * c2 + 6 * c3 * tau
        return v, a
    a0, a1 = acc[k], acc[k + 1]
    c2 = 0.5 * a0
    c3 = (-20 * p0 + 20 * p1 - 3 * a0 * h**2 + a1 * h**2 - 12 * v0 * h - 8 * v1 * h) / (2 * h**3)
    c4 = (30 * p0 - 30 * p1 + 3 * a0 * h**2 - 2 * a1 * h**2 + 16 * v0 * h + 14 * v1 * h) / (2 * h**4)
    c5 = (-12 * p0 + 12 * p1 - a0 * h**2 + a1 * h**2 - 6 * v0 * h - 6 * v1 * h) / (2 * h**5)
    v = v0 + 2 * c2 * tau + 3 * c3 * tau**2 + 4 * c4 * tau**3 + 5 * c5 * tau**4
    a = 2 * c2 + 6 * c3 * tau + 12 * c4 * tau**2 + 20 * c5 * tau**3
    return v, a


CASES = [(seed, cap) for seed in range(6) for cap in (None, 30.0 + 10.0 * seed)]


@pytest.mark.parametrize("seed,cap", CASES)
def test_duration_near_toppra_and_limits_hold_at_1ms(topp_json, seed, cap):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 501))
    q = random_path(rng, n)
    req = {"positions": q.tolist(), "velocity": VEL.tolist(), "acceleration": ACC.tolist()}
    if cap is not None:
        req["tip_speed_cap"] = cap
    run = subprocess.run([topp_json], input=json.dumps(req), capture_output=True, text=True, check=True)
    out = json.loads(run.stdout)
    s = np.array(out["s"])
    ours = out["duration"]
    theirs = toppra_duration(s, q, cap)
    print(f"seed {seed} cap {cap} n {len(q)}: ours {ours:.4f} s toppra {theirs:.4f} s ratio {ours / theirs:.4f}")
    assert ours <= 1.02 * theirs, (ours, theirs)
    # Far below toppra's optimum would mean a constraint was dropped.
    assert ours >= 0.97 * theirs, (ours, theirs)

    tr = out["trajectory"]
    times = np.array(tr["times"])
    pos, vel = np.array(tr["positions"]), np.array(tr["velocities"])
    acc = np.array(tr["accelerations"]) if tr["accelerations"] else None
    assert np.all(np.diff(times) > 0)
    np.testing.assert_allclose(pos[0], q[0], atol=1e-9)
    np.testing.assert_allclose(pos[-1], q[-1], atol=1e-9)
    v, a = jtc_sample(times, pos, vel, acc)
    assert np.max(np.abs(v) / VEL) <= 1.0 + 1e-9
    assert np.max(np.abs(a) / ACC) <= 1.0 + 1e-9
    if cap is not None:
        assert np.max(np.linalg.norm(v[:, :3], axis=1)) <= cap * (1.0 + 1e-9)
    # The geometric path: the trajectory's points lie on the same spline.
    spline = CubicSpline(s, q, bc_type="natural")
    np.testing.assert_allclose(spline(np.array(tr["s"])), pos, rtol=0, atol=1e-7)
