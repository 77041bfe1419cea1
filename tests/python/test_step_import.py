"""`toolpath import` on STEP parts written here and now by Open CASCADE
(cadquery-ocp, tests/python/make_step_parts.py): every face's area as
listed against BRepGProp's, the written surface planned by `toolpath plan`
and judged by its simulator within h, and the committed fixtures
(tests/data/step) still what the generator writes."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from toolpath_bin import ROOT, toolpath_bin

HERE = Path(__file__).resolve().parent
AREA_REL = 5e-4


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    out = tmp_path_factory.mktemp("step")
    subprocess.run(
        [sys.executable, str(HERE / "make_step_parts.py"), str(out)],
        check=True,
        capture_output=True,
    )
    return out, json.loads((out / "parts.json").read_text())


def listed(path):
    r = subprocess.run([toolpath_bin(), "import", str(path), "--list"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = [l for l in r.stdout.splitlines() if re.match(r"\s*#\d+", l)]
    return [(int(l.split()[0][1:]), l.split()[1], float(l.split()[2])) for l in rows]


def test_listed_areas_are_open_cascades(parts):
    out, manifest = parts
    for name, part in manifest.items():
        rows = listed(out / part["file"])
        assert len(rows) == 1, rows
        _, kind, area = rows[0]
        exact = part["area_mm2"]
        assert abs(area - exact) <= AREA_REL * exact, (name, kind, area, exact)


def test_the_fixtures_match_the_generator(parts):
    _, manifest = parts
    committed = json.loads((ROOT / "tests/data/step/parts.json").read_text())
    assert committed.keys() == manifest.keys()
    for name in manifest:
        assert committed[name]["area_mm2"] == pytest.approx(manifest[name]["area_mm2"], rel=1e-9)


def test_an_imported_face_is_planned_within_h(parts, tmp_path):
    out, _ = parts
    surface = tmp_path / "face.json"
    face = listed(out / "freeform.step")[0][0]
    r = subprocess.run(
        [toolpath_bin(), "import", str(out / "freeform.step"), "--face", str(face), "-o", str(surface)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    s = json.loads(surface.read_text())
    assert s["kind"] == "nurbs" and len(s["trim"]["holes"]) == 1
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "job_id": "step_face",
                "surface": s,
                "strategy": "iso_parametric",
                "tool": {"kind": "ball", "radius": 4.0},
                "scallop": 0.05,
            }
        )
    )
    result = tmp_path / "result.json"
    r = subprocess.run([toolpath_bin(), "plan", str(job), "-o", str(result)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = json.loads(result.read_text())
    assert res["within_scallop"] is True
    assert res["stats"]["max_scallop_mm"] <= 0.05


def test_bad_step_input_exits_2_naming_the_entity(parts, tmp_path):
    out, _ = parts
    text = (out / "cylinder.step").read_text()
    cut = tmp_path / "cut.step"
    cut.write_text(text[: len(text) // 2])
    r = subprocess.run([toolpath_bin(), "import", str(cut), "--list"], capture_output=True, text=True)
    assert r.returncode == 2 and "truncated" in r.stderr, r.stderr
    r = subprocess.run(
        [toolpath_bin(), "import", str(out / "cylinder.step"), "--face", "4242", "-o", str(tmp_path / "x.json")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "#4242" in r.stderr, r.stderr


STEP_SAMPLES = ("step_freeform", "step_multi_face")


def occ_face_areas(path):
    """Areas of the faces of a STEP file as Open CASCADE reads them, in shell order."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    ex = TopExp_Explorer(reader.OneShape(), TopAbs_FACE)
    areas = []
    while ex.More():
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(ex.Current(), props)
        areas.append(props.Mass())
        ex.Next()
    return areas


@pytest.mark.parametrize("name", STEP_SAMPLES)
def test_step_samples_list_open_cascades_areas(name, tmp_path):
    part = tmp_path / f"{name}.step"
    r = subprocess.run([toolpath_bin(), "sample", name, "-o", str(part)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    again = tmp_path / "again.step"
    subprocess.run([toolpath_bin(), "sample", name, "-o", str(again)], check=True)
    assert part.read_bytes() == again.read_bytes()
    rows = listed(part)
    occ = occ_face_areas(part)
    assert len(rows) == len(occ) == (1 if name == "step_freeform" else 4), (rows, occ)
    for (face, kind, area), exact in zip(rows, occ):
        assert abs(area - exact) <= AREA_REL * exact, (name, face, kind, area, exact)


def test_a_step_sample_face_named_by_a_job_plans_within_h(tmp_path):
    part = tmp_path / "part.step"
    subprocess.run([toolpath_bin(), "sample", "step_multi_face", "-o", str(part)], check=True)
    face = listed(part)[0][0]
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "job_id": "step_sample_face",
                "surface": {"file": "part.step", "face": face},
                "strategy": "iso_scallop",
                "tool": {"kind": "ball", "radius": 4.0},
                "scallop": 0.05,
            }
        )
    )
    result = tmp_path / "result.json"
    r = subprocess.run([toolpath_bin(), "plan", str(job), "-o", str(result)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = json.loads(result.read_text())
    assert res["within_scallop"] is True
    assert res["stats"]["max_scallop_mm"] <= 0.05
