"""Mould cavities (cavities.py) through `toolpath`: the importer names the
faces as the oracle does, and a planned floor is checked against the whole
part by the oracle (part_oracle.py). Until planning checks the tool against
the part's other faces the plan check ends in xfail with the oracle's
figures (a plan that fails to run is a failure); it passes the day no pose
cuts a check face or touches the holder."""

import json
import re
import subprocess

import pytest

from cavities import CavitySpec, build_cavity, face_area
from part_oracle import PartOracle, check_result
from tool_assembly import ToolAssembly
from toolpath_bin import toolpath_bin

# `--list` integrates a trimmed face on 128 x 128 cells over its surface's
# whole (u, v) domain; the cavity floor's surface reaches 10 mm beyond the
# face on every side, so fewer cells fall on the face than on the import
# test parts (AREA_REL 5e-4 there).
AREA_REL = 2e-3
HOLDER = [{"length": 40, "radius": 5}, {"length": 60, "radius": 16}]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return build_cavity(spec=CavitySpec.reference(), out_dir=tmp_path_factory.mktemp("cavity"), name="reference")


def listing(step):
    r = subprocess.run([toolpath_bin(), "import", str(step), "--list"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = {}
    for line in r.stdout.splitlines():
        m = re.match(r"\s*#(\d+)\s+(\S+)\s+(\S+)\s+(.*)$", line)
        if m:
            rows[int(m.group(1))] = (m.group(2), m.group(3), m.group(4))
    return rows


@pytest.mark.parametrize("seed", [None, 1, 4])
def test_the_importer_lists_the_faces_the_oracle_names(seed, reference, tmp_path):
    """Every ADVANCED_FACE the oracle keys a face by is a face of the
    listing, with Open CASCADE's area where it imports, and a reason naming
    the entity where it does not."""
    cav = reference if seed is None else build_cavity(seed, tmp_path)
    rows = listing(cav.step_path)
    assert sorted(rows) == sorted(cav.faces)
    for fid, (kind, area, rest) in rows.items():
        assert kind == cav.face_types[fid] or (kind == "RATIONAL_B_SPLINE_SURFACE" and cav.face_types[fid].endswith("B_SPLINE_SURFACE")), (
            fid,
            kind,
        )
        if area == "-":
            assert "not importable" in rest and f"#{fid}" in rest or "#" in rest, (fid, rest)
            continue
        exact = face_area(cav.faces[fid])
        assert abs(float(area) - exact) <= AREA_REL * exact, (fid, cav.role(fid), area, exact)


def test_a_planned_floor_keeps_the_cutter_out_of_its_neighbours(reference, tmp_path):
    floor = reference.groups["floor"]
    job = {
        "job_id": "cavity_floor",
        "surface": {"file": str(reference.step_path), "face": floor[0]},
        "strategy": "tensor_regions",
        "tool": {"kind": "flat_end", "radius": 5.0, "length": 30.0},
        "scallop": 0.05,
        "lead_angle_deg": 5.0,
    }
    (tmp_path / "job.json").write_text(json.dumps(job))
    r = subprocess.run(
        [toolpath_bin(), "plan", str(tmp_path / "job.json"), "-o", str(tmp_path / "result.json")], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    result = json.loads((tmp_path / "result.json").read_text())
    oracle = PartOracle(reference.solid, reference.faces, spacing=1.0, face_spacing=reference.oracle_spacing(3.0))
    tool = ToolAssembly.from_json({"kind": "flat_end", "radius": 5.0, "flute_length": 30.0, "holder": HOLDER})
    s = check_result(oracle, result, tool, floor).summary()
    assert s["poses"] == sum(len(p["points"]) for p in result["passes"]) > 0
    assert s["gouge_poses"] == 0, s  # the planner's own simulator judges the floor
    holder = sum(h["collision_poses"] for h in s["holder"].values())
    if s["check_cut_poses"] or holder:
        pytest.xfail(
            f"planning does not check the part's other faces yet: {s['check_cut_poses']} of {s['poses']} poses cut "
            f"a check face by more than 0.01 mm ({s['check_cut_over_1mm']} by more than 1 mm, the cutter up to "
            f"{s['max_material_depth_mm']:.1f} mm into the material), {holder} holder collisions"
        )
