"""Self-tests of the part oracle (part_oracle.py, tool_assembly.py,
face_samples.py): clearances of poses placed by construction at known
distances from simple Open CASCADE solids, a pose pushed into a wall, the
closed-form signed distance against BRepExtrema and the solid classifier, the
samples' covering radius, and random poses against BRepExtrema and against a
brute-force dense sampling of a fine tessellation."""

import math

import numpy as np
import pytest
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
from OCP.BRepClass3d import BRepClass3d_SolidClassifier
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
from OCP.TopAbs import TopAbs_IN

from cavities import CavitySpec, build_cavity, edges_of
from part_oracle import LinksMissing, PartOracle, check_result, link_sampling_faults, result_links
from tool_assembly import Segment, ToolAssembly, ToolError

EXACT = 1e-3  # mm: what the oracle must get right near contact
HOLDER = [{"length": 40, "radius": 5}, {"length": 20, "radius_bottom": 8, "radius_top": 16}, {"length": 40, "radius": 16}]
TOOLS = {
    "flat_end": {"kind": "flat_end", "radius": 5, "flute_length": 30, "holder": HOLDER},
    "ball": {"kind": "ball", "radius": 4, "flute_length": 25, "holder": HOLDER},
    "torus": {"kind": "torus", "radius": 6, "corner_radius": 2, "flute_length": 25, "holder": HOLDER},
}


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


@pytest.fixture(scope="module")
def box():
    """100 x 80 x 40 mm, faces numbered in explorer order."""
    return PartOracle.from_shape(BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(100, 80, 40)).Shape(), spacing=1.0)


@pytest.fixture(scope="module")
def hole():
    """An 80 x 80 x 40 block with a through hole of radius 20 about (40, 40)."""
    block = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(80, 80, 40)).Shape()
    cyl = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(40, 40, -1), gp_Dir(0, 0, 1)), 20.0, 42.0).Shape()
    return PartOracle.from_shape(BRepAlgoAPI_Cut(block, cyl).Shape(), spacing=1.0)


@pytest.fixture(scope="module")
def step_block():
    """An L block: 60 x 60 x 40 with the box x > 20, z > 20 removed and its
    concave edge (x = 20, z = 20, along y) filleted with radius 8: a
    cylinder about the line x = 28, z = 28."""
    block = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(60, 60, 40)).Shape()
    cut = BRepPrimAPI_MakeBox(gp_Pnt(20, -1, 20), gp_Pnt(61, 61, 41)).Shape()
    solid = BRepAlgoAPI_Cut(block, cut).Shape()
    fil = BRepFilletAPI_MakeFillet(solid)
    for e in edges_of(solid):
        from OCP.BRepAdaptor import BRepAdaptor_Curve

        c = BRepAdaptor_Curve(e)
        a, b = c.Value(c.FirstParameter()), c.Value(c.LastParameter())
        if abs(a.X() - 20) < 1e-9 and abs(b.X() - 20) < 1e-9 and abs(a.Z() - 20) < 1e-9 and abs(b.Z() - 20) < 1e-9:
            fil.Add(8.0, e)
    fil.Build()
    assert fil.IsDone()
    return PartOracle.from_shape(fil.Shape(), spacing=1.0)


@pytest.fixture(scope="module")
def cavity(tmp_path_factory):
    cav = build_cavity(spec=CavitySpec.reference(), out_dir=tmp_path_factory.mktemp("cavity"), name="reference")
    return cav, PartOracle(cav.solid, cav.faces, spacing=1.0, face_spacing=cav.oracle_spacing(3.0))


# -- the tool's closed form ---------------------------------------------------


def all_segments():
    segs = []
    for t in TOOLS.values():
        segs += list(ToolAssembly.from_json(t).segments)
    return segs


def test_scalar_and_vector_signed_distances_agree():
    rng = np.random.default_rng(7)
    for seg in all_segments():
        rho = rng.uniform(0, 2 * seg.radius + 2, 400)
        z = rng.uniform(seg.z0 - 5, seg.z1 + 5, 400)
        vec = seg.local_sd(rho, z)
        sca = np.array([seg.local_sd_scalar(r, h) for r, h in zip(rho, z)])
        np.testing.assert_allclose(vec, sca, atol=1e-12)


def test_signed_distance_is_brepextrema_outside_and_the_classifier_inside():
    """Outside a posed segment, sd is the BRepExtrema distance from the point
    to the segment's primitive solids; inside, the classifier agrees, and on
    single-primitive segments -sd is the distance to the solid's boundary."""
    rng = np.random.default_rng(11)
    tip, axis = np.array([3.0, -2.0, 1.0]), unit([0.3, -0.2, 1.0])
    for seg in all_segments():
        solids = seg.solids(tip, axis)
        pts = tip + rng.normal(size=(40, 3)) * seg.radius + np.outer(rng.uniform(seg.z0 - 3, seg.z1 + 3, 40), axis)
        sd = seg.sd(pts, tip, axis)
        for p, d in zip(pts, sd):
            v = BRepBuilderAPI_MakeVertex(gp_Pnt(*p)).Vertex()
            inside = any(_classify(s, p) for s in solids)
            assert inside == (d < 0), (seg.name, p, d)
            if d > 0:
                ext = min(BRepExtrema_DistShapeShape(v, s).Value() for s in solids)
                assert abs(ext - d) < 1e-6, (seg.name, p, d, ext)
            elif len(solids) == 1:
                from OCP.TopAbs import TopAbs_SHELL
                from OCP.TopExp import TopExp_Explorer

                shell = TopExp_Explorer(solids[0], TopAbs_SHELL).Current()
                ext = BRepExtrema_DistShapeShape(v, shell).Value()
                assert abs(ext + d) < 1e-6, (seg.name, p, d, ext)


def _classify(solid, p):
    c = BRepClass3d_SolidClassifier(solid, gp_Pnt(*p), 1e-9)
    return c.State() == TopAbs_IN


def test_bad_tools_are_refused_naming_the_field():
    with pytest.raises(ToolError, match=r"tool.radius: must be a positive number"):
        ToolAssembly.from_json({"kind": "flat_end", "radius": -1})
    with pytest.raises(ToolError, match=r"tool.holder\[1\].length: is required"):
        ToolAssembly.from_json({"kind": "ball", "radius": 3, "holder": [{"length": 4, "radius": 3}, {"radius": 5}]})
    with pytest.raises(ToolError, match=r"tool.corner_radius: must be below"):
        ToolAssembly.from_json({"kind": "torus", "radius": 3, "corner_radius": 3})
    t = ToolAssembly.from_json({"kind": "ball", "radius": 3, "length": 12, "holder": [{"length": 4, "radius_bottom": 3, "radius_top": 6}]})
    assert [(s.z0, s.z1) for s in t.segments] == [(0.0, 12.0), (12.0, 16.0)]


# -- clearances by construction ----------------------------------------------


def test_box_clearances_by_construction(box):
    t = {k: ToolAssembly.from_json(v) for k, v in TOOLS.items()}
    for c in (0.0, 0.05, 0.4, 0.9):
        # Above the top face z = 40, vertical and tilted by 20 deg about y.
        got = box.check_segment(t["flat_end"].cutter, (50, 40, 40 + c), (0, 0, 1))
        assert abs(got.value - c) < EXACT and got.exact, got
        th = math.radians(20)
        a = (math.sin(th), 0, math.cos(th))
        got = box.check_segment(t["flat_end"].cutter, (50, 40, 40 + c + 5 * math.sin(th)), a)
        assert abs(got.value - c) < EXACT, got
        # A tilted torus: its lowest point rc cos th - (R - rc) sin th - rc
        # above the tip (the tube circle's lowest point, minus the tube).
        low = 2 * math.cos(th) - 4 * math.sin(th) - 2
        got = box.check_segment(t["torus"].cutter, (50, 40, 40 + c - low), a)
        assert abs(got.value - c) < EXACT, got
        # A tilted ball: its centre R above its lowest point.
        a = unit((1, 2, 3))
        got = box.check_segment(t["ball"].cutter, np.array([30, 20, 40 + c + 4]) - 4 * a, a)
        assert abs(got.value - c) < EXACT, got
        # Beside the wall x = 0, outside the box: the side at c from it.
        got = box.check_segment(t["flat_end"].cutter, (-5 - c, 40, 20), (0, 0, 1))
        assert abs(got.value - c) < EXACT, got
        # The holder's cone (radius 8 at its bottom, 70 mm above the tip) above the top face.
        cone = t["flat_end"].holder[1]
        got = box.check_segment(cone, (50, 40, 40 + c - cone.z0), (0, 0, 1))
        assert abs(got.value - c) < EXACT, got


def test_a_cutter_pushed_into_a_box_wall_reads_the_depth(box):
    cutter = ToolAssembly.from_json(TOOLS["flat_end"]).cutter
    for d in (0.01, 0.5, 2.0):
        got = box.check_segment(cutter, (-5 + d, 40, 20), (0, 0, 1))
        assert abs(got.value + d) < EXACT and got.exact, (d, got)
    # A ball cutter outside the wall y = 80, tilted away from it, its sphere
    # 0.5 mm into the wall.
    ball = ToolAssembly.from_json(TOOLS["ball"]).cutter
    a = unit((0, 1, 1))
    centre_y = 80 + 4 - 0.5
    tip = np.array([50, centre_y, 20]) - 4 * a
    got = box.check_segment(ball, tip, a)
    assert abs(got.value + 0.5) < EXACT, got


def test_hole_clearances_by_construction(hole):
    t = ToolAssembly.from_json(TOOLS["flat_end"])
    for e in (0.0, 1.5, 3.5):
        tip = (40 + e, 40, 5)
        got = hole.check_segment(t.cutter, tip, (0, 0, 1))
        assert abs(got.value - (20 - 5 - e)) < EXACT or got.value >= hole.band - 1e-9, got
        # The 16 mm holder sits 0..40 mm above the shank: put it in the hole.
        seg = t.holder[2]
        got = hole.check_segment(seg, (40 + e, 40, -seg.z0 + 5), (0, 0, 1))
        assert abs(got.value - (4 - e)) < EXACT or got.value >= hole.band - 1e-9, got
        if 4 - e < hole.band:
            assert got.exact
    # The cone from radius 8 to 16 over 20 mm, its top 10 mm inside the hole:
    # its widest circle (16) at 4 - e from the wall.
    cone = t.holder[1]
    got = hole.check_segment(cone, (40.5, 40, 30 - cone.z1), (0, 0, 1))
    assert abs(got.value - 3.5) < EXACT or got.value >= hole.band - 1e-9, got
    got = hole.check_segment(cone, (43.6, 40, 30 - cone.z1), (0, 0, 1))
    assert abs(got.value - 0.4) < EXACT and got.exact, got
    # 0.3 mm radially into the wall at its top rim: the wall's deepest point
    # is t below the top where the top and the slanted side are equally far:
    # t = (0.3 x 20) / (8 + sqrt(20^2 + 8^2)) (side slope 8 over 20).
    got = hole.check_segment(cone, (44.3, 40, 30 - cone.z1), (0, 0, 1))
    assert abs(got.value + 6.0 / (8.0 + math.hypot(20.0, 8.0))) < EXACT, got


def test_fillet_clearance_by_construction(step_block):
    """A ball of radius 3 centred at distance d from the fillet's axis,
    towards the corner: 8 - d - 3 from the fillet."""
    ball = ToolAssembly.from_json({"kind": "ball", "radius": 3, "flute_length": 3}).cutter
    toward = unit((-1, 0, -1))
    for d in (4.0, 4.6, 4.95, 5.2):
        centre = np.array([28.0, 30.0, 28.0]) + d * toward
        axis = unit((1, 0, 1))
        tip = centre - 3 * axis
        got = step_block.check_segment(ball, tip, axis)
        assert abs(got.value - (5 - d)) < EXACT, (d, got)


# -- the cavity ---------------------------------------------------------------


def wall_frame(cav):
    """A point in the middle of the wall facing -x (the wall at the small x
    end), its inward normal and the direction up the wall."""
    s = cav.spec
    t = math.tan(math.radians(s.draft_deg))
    x_top = (s.length - s.opening_length) / 2.0
    n = unit((math.cos(math.radians(s.draft_deg)), 0, t * math.cos(math.radians(s.draft_deg))))
    up = unit((-t, 0, 1))
    z = s.height - 0.45 * s.depth
    p = np.array([x_top + (s.height - z) * t, s.width / 2.0, z])
    return p, n, up


def test_a_pose_pushed_into_a_drafted_wall_is_flagged_with_its_depth(cavity):
    cav, oracle = cavity
    p, n, up = wall_frame(cav)
    tool = ToolAssembly.from_json({"kind": "flat_end", "radius": 5, "flute_length": 12})
    floor = cav.groups["floor"]
    for d in (0.5, 0.02, -0.3):
        # Axis along the wall, the cutter's side d into it.
        tip = p + (5 - d) * n - 6 * up
        got = oracle.check_pose(tool, tip, up, floor)
        assert got.gouge.value >= oracle.band - 1e-9, got  # far above the floor
        assert abs(got.check.value + d) < EXACT, (d, got)
        assert cav.role(got.check.face) == "walls", got
        assert abs(got.check_depth_mm - max(d, 0)) < EXACT


def test_a_ball_pushed_into_the_freeform_floor_reads_the_depth(cavity):
    cav, oracle = cavity
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.gp import gp_Vec

    floor_id = cav.groups["floor"][0]
    face = cav.faces[floor_id]
    ad = BRepAdaptor_Surface(face)
    tool = ToolAssembly.from_json({"kind": "ball", "radius": 4, "flute_length": 20})
    rng = np.random.default_rng(3)
    for _ in range(6):
        u = ad.FirstUParameter() + rng.uniform(0.3, 0.7) * (ad.LastUParameter() - ad.FirstUParameter())
        v = ad.FirstVParameter() + rng.uniform(0.3, 0.7) * (ad.LastVParameter() - ad.FirstVParameter())
        p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
        ad.D1(u, v, p, du, dv)
        n = unit(np.cross([du.X(), du.Y(), du.Z()], [dv.X(), dv.Y(), dv.Z()]))
        n = n if n[2] > 0 else -n
        for d in (0.3, 0.004):
            centre = np.array([p.X(), p.Y(), p.Z()]) + (4 - d) * n
            got = oracle.check_pose(tool, centre - 4 * n, n, [floor_id])
            assert abs(got.gouge.value + d) < EXACT and got.gouge.face == floor_id, (d, got)


def test_samples_cover_every_face_within_their_radius(cavity):
    """Random points of every face (random (u, v) kept on the face) lie
    within the covering radius of a sample."""
    cav, oracle = cavity
    rng = np.random.default_rng(5)
    s = oracle.samples
    for k, ctx in enumerate(s.faces):
        u0, u1, v0, v1 = ctx.bounds
        pts = []
        while len(pts) < 150:
            u, v = rng.uniform(u0, u1), rng.uniform(v0, v1)
            if ctx.inside(u, v):
                pts.append(ctx.point(u, v))
        mine = np.flatnonzero(s.face == k)
        d = np.min(np.linalg.norm(np.asarray(pts)[:, None, :] - s.points[mine][None, :, :], axis=2), axis=1)
        assert d.max() <= s.rho[mine[0]], (ctx.face_id, cav.role(ctx.face_id), d.max(), s.rho[mine[0]])


def random_poses(cav, n, rng):
    """Poses near the cavity's floor, fillets and walls: tips in the cavity's
    lower part, axes within 40 deg of vertical."""
    s = cav.spec
    out = []
    while len(out) < n:
        x = rng.uniform((s.length - s.opening_length) / 2 - 2, (s.length + s.opening_length) / 2 + 2)
        y = rng.uniform((s.width - s.opening_width) / 2 - 2, (s.width + s.opening_width) / 2 + 2)
        z = float(s.floor_height(x, y)) + rng.uniform(-1.0, 3.0)
        th, ph = math.radians(rng.uniform(0, 40)), rng.uniform(0, 2 * math.pi)
        out.append((np.array([x, y, z]), np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])))
    return out


def mesh_min(seg, tip, axis, verts, tris, tol=0.002):
    """Brute force over a tessellation: the smallest sd of the posed segment
    over the triangles, by splitting every triangle that may still hold a
    value more than `tol` below the best found (sd is 1-Lipschitz: a
    triangle's values are at least sd(centroid) - its radius) into four,
    until none may. Returns a value within `tol` of the mesh's minimum."""
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    best = float(seg.sd(verts, tip, axis).min())
    while len(a):
        cen = (a + b + c) / 3.0
        rad = np.sqrt(np.max([np.einsum("ij,ij->i", p - cen, p - cen) for p in (a, b, c)], axis=0))
        sd = seg.sd(cen, tip, axis)
        best = min(best, float(sd.min()))
        keep = sd - rad < best - tol
        a, b, c = a[keep], b[keep], c[keep]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        best = min(best, float(min(seg.sd(m, tip, axis).min(initial=math.inf) for m in (ab, bc, ca))))
        a, b, c = np.concatenate([a, ab, ca, ab]), np.concatenate([ab, b, bc, bc]), np.concatenate([ca, bc, c, ca])
        assert len(a) < 4_000_000, "the brute force does not converge"
    return best


def test_random_poses_against_a_dense_sampling_of_a_fine_tessellation(cavity):
    """The oracle's figure (exact within its band) against the brute force
    over a tessellation within 0.003 mm of the faces: equal within the
    deflection plus the brute force's tolerance (0.002) and the oracle's
    optimiser's (1e-4)."""
    cav, oracle = cavity
    verts, tris, _ = cav.tessellation(deflection=0.003, angular=0.1)
    rng = np.random.default_rng(2024)
    compared = 0
    for k, (tip, axis) in enumerate(random_poses(cav, 12, rng)):
        tool = ToolAssembly.from_json(list(TOOLS.values())[k % 3])
        seg = tool.cutter
        got = oracle.check_segment(seg, tip, axis)
        if not got.exact:
            assert got.value >= oracle.band - oracle.rho - 1e-9
            continue
        brute = mesh_min(seg, tip, axis, verts, tris)
        assert abs(got.value - brute) < 0.0052, (k, tip, axis, got, brute)
        compared += 1
    assert compared >= 6


def test_random_clear_poses_against_brepextrema(cavity):
    """Positive clearances of random poses (cutter and holder) equal
    BRepExtrema_DistShapeShape's between the segment's solids and the part."""
    cav, oracle = cavity
    rng = np.random.default_rng(99)
    compared = 0
    for k, (tip, axis) in enumerate(random_poses(cav, 40, rng)):
        tool = ToolAssembly.from_json(list(TOOLS.values())[k % 3])
        lift = tip + np.array([0, 0, rng.uniform(0.0, 1.5)])
        got = oracle.check_segment(tool.cutter, lift, axis)
        if not (got.exact and 0.0 < got.value):
            continue
        ext = oracle.extrema_clearance(tool.cutter, lift, axis)
        assert abs(ext - got.value) < EXACT, (k, got, ext)
        compared += 1
        if compared == 6:
            break
    assert compared >= 4


def test_a_buried_holder_is_reported(box):
    """A shank segment wholly inside the box (z 10..25, 10 mm from every
    face) reads minus its axis middle's depth, 17.5 mm below the nearest
    face; lifted 1.5 mm above the box it is clear."""
    seg = Segment("shank", 30.0, 45.0, 5.0, 5.0)
    got = box.check_segment(seg, (50, 40, 10 - seg.z0), (0, 0, 1))
    assert got.buried and abs(got.value + 17.5) <= box.rho, got
    got = box.check_segment(seg, (50, 40, 41.5 - seg.z0), (0, 0, 1))
    assert not got.buried and got.value >= box.band - box.rho - 1e-9, got


# -- results and links ---------------------------------------------------------


def synthetic_result(points, links=None):
    res = {"job_id": "x", "strategy": "iso_parametric", "passes": [{"region": 0, "points": points}]}
    if links is not None:
        res["links"] = links
    return res


def test_a_result_without_links_is_checked_and_the_links_skipped(box):
    tool = ToolAssembly.from_json(TOOLS["flat_end"])
    top = 6  # the face z = 40 in the box's explorer order
    pts = [{"cc": [50 + i, 40, 40], "cl": [50 + i, 40, 40], "axis": [0, 0, 1]} for i in range(5)]
    pts.append({"cc": [2, 40, 40], "cl": [2, 40, 40], "axis": [0, 0, 1]})  # the side hangs over x = 0
    pts.append({"cc": [50, 40, 40], "cl": [50, 40, 39.5], "axis": [0, 0, 1]})  # 0.5 into the top
    checked = check_result(box, synthetic_result(pts), tool, [top])
    s = checked.summary()
    assert s["poses"] == 7 and s["poses_cc_on_face"] == 7
    assert s["gouge_poses"] == 1 and abs(s["max_gouge_mm"] - 0.5) < EXACT
    assert "no `links`" in s["links"]["skipped"]
    with pytest.raises(LinksMissing):
        result_links(synthetic_result(pts))


def test_links_are_checked_and_their_sampling_judged(box):
    tool = ToolAssembly.from_json(TOOLS["flat_end"])
    down = [{"tip": [50, 40, 60 - z], "axis": [0, 0, 1]} for z in np.arange(0, 21.0, 1.0)]  # to z = 40
    dive = [{"tip": [50, 40, 45], "axis": [0, 0, 1]}, {"tip": [50, 40, 38], "axis": [0, 0, 1]}]  # 7 mm step, 2 into the part
    turn = [{"tip": [50, 40, 60], "axis": [0, 0, 1]}, {"tip": [50, 40, 60], "axis": list(unit([math.sin(0.1), 0, math.cos(0.1)]))}]
    pts = [{"cc": [50, 40, 40], "cl": [50, 40, 40], "axis": [0, 0, 1]}]
    res = synthetic_result(pts, links=[{"poses": down}, dive, {"poses": turn}])
    links = result_links(res)
    faults = link_sampling_faults(links)
    assert [(f[0], f[1]) for f in faults] == [(1, 1), (2, 1)]
    assert abs(faults[0][2] - 7.0) < 1e-12 and abs(faults[1][3] - math.degrees(0.1)) < 1e-9
    s = check_result(box, res, tool, [6]).summary()["links"]
    assert s["links"] == 3 and s["poses"] == 25 and s["sampling_faults"] == 2
    assert s["cutter"]["collision_poses"] == 1 and abs(s["cutter"]["min_clearance_mm"] + 2.0) < EXACT


def test_face_classification_of_the_family(tmp_path):
    """Seeded parts: the roles add up, the floor lies on its height field
    (within 0.05 mm: the B-spline interpolates it at 11 x 11 points), and the
    walls' draft is the spec's."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    for seed in (0, 1, 3):
        cav = build_cavity(seed, tmp_path)
        g = cav.groups
        assert (len(g["floor"]), len(g["floor_fillets"]), len(g["corner_fillets"]), len(g["walls"])) == (1, 8, 4, 4), g
        assert len(cav.faces) == 23
        for fid in g["walls"]:
            n = BRepAdaptor_Surface(cav.faces[fid]).Plane().Axis().Direction()
            tilt = math.degrees(math.asin(min(1.0, abs(n.Z()))))
            assert abs(tilt - cav.spec.draft_deg) < 1e-6, (seed, fid, tilt, cav.spec.draft_deg)
        ad = BRepAdaptor_Surface(cav.faces[g["floor"][0]])
        for s, t in ((0.5, 0.5), (0.4, 0.6)):
            p = ad.Value(
                ad.FirstUParameter() + s * (ad.LastUParameter() - ad.FirstUParameter()),
                ad.FirstVParameter() + t * (ad.LastVParameter() - ad.FirstVParameter()),
            )
            assert abs(p.Z() - float(cav.spec.floor_height(p.X(), p.Y()))) < 0.05
