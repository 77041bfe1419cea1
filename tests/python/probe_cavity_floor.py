"""Plans the floor of a mould cavity with today's `toolpath plan` and checks
every pose against the exact part with part_oracle; lists what
`toolpath import --list` makes of every face of the part.

    python3 tests/python/probe_cavity_floor.py [--seed N | --reference] [--depth D]
        [--strategy S] [--radius R] [--scallop H] [--lead-deg L] [--out DIR] [--json FILE]

Prints the figures as JSON: the part, the STEP surface entities written, the
import listing (faces refused and why), the plan's exit and figures, the
oracle's summary (poses cutting a check face by more than 0.01 mm and 1 mm,
the deepest, holder clearances, links), and the times.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from cavities import CavitySpec, build_cavity, face_area, surface_survey
from part_oracle import PartOracle, check_result
from tool_assembly import ToolAssembly
from toolpath_bin import toolpath_bin

HOLDER = [{"length": 40, "radius": 5}, {"length": 60, "radius": 16}]


def import_listing(step):
    """`toolpath import --list`: {id: {"type", "area_mm2"} or {"type", "error"}}."""
    r = subprocess.run([toolpath_bin(), "import", str(step), "--list"], capture_output=True, text=True)
    if r.returncode != 0:
        return {"exit": r.returncode, "stderr": r.stderr.strip()}
    rows = {}
    for line in r.stdout.splitlines():
        m = re.match(r"\s*#(\d+)\s+(\S+)\s+(.*)$", line)
        if not m:
            continue
        rest = m.group(3)
        num = re.match(r"([0-9.eE+-]+)\s", rest + " ")
        try:
            rows[int(m.group(1))] = {"type": m.group(2), "area_mm2": float(num.group(1))}
        except (AttributeError, ValueError):
            rows[int(m.group(1))] = {"type": m.group(2), "error": rest.strip()}
    return rows


def face_import_errors(step, faces):
    """`toolpath import --face ID` per face: the message of each refusal."""
    out = {}
    for fid in faces:
        r = subprocess.run([toolpath_bin(), "import", str(step), "--face", str(fid), "-o", "/dev/null"], capture_output=True, text=True)
        if r.returncode != 0:
            out[fid] = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else f"exit {r.returncode}"
    return out


def plan(job, work):
    path = work / "job.json"
    path.write_text(json.dumps(job))
    result = work / "result.json"
    t = time.time()
    r = subprocess.run([toolpath_bin(), "plan", str(path), "-o", str(result)], capture_output=True, text=True)
    out = {"exit": r.returncode, "plan_s": round(time.time() - t, 1), "stderr": r.stderr.strip()[-2000:]}
    if result.exists():
        res = json.loads(result.read_text())
        out["result"] = res
        out["status_line"] = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int)
    ap.add_argument("--reference", action="store_true", help="the 160 x 120 x 60 reference cavity (default)")
    ap.add_argument("--depth", type=float, default=35.0, help="reference cavity depth")
    ap.add_argument("--strategy", default="tensor_regions")
    ap.add_argument("--kind", default="flat_end")
    ap.add_argument("--radius", type=float, default=5.0)
    ap.add_argument("--corner-radius", type=float, default=2.0)
    ap.add_argument("--flute-length", type=float, default=30.0)
    ap.add_argument("--scallop", type=float, default=0.05)
    ap.add_argument("--lead-deg", type=float, default=5.0, help="the milling samples' lead angle")
    ap.add_argument("--spacing", type=float, default=0.5)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    work = a.out or Path(tempfile.mkdtemp(prefix="cavity_probe_"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    if a.seed is not None:
        cav = build_cavity(a.seed, work)
    else:
        cav = build_cavity(spec=CavitySpec.reference(a.depth), out_dir=work, name="reference")
    report = {"part": cav.manifest(), "build_s": round(time.time() - t0, 1)}
    report["step_surfaces"] = {str(k): v for k, v in surface_survey(cav.step_path).items()}
    listing = import_listing(cav.step_path)
    report["import_list"] = {str(k): v for k, v in listing.items()}
    report["import_errors"] = {str(k): v for k, v in face_import_errors(cav.step_path, sorted(cav.faces)).items()}
    report["area_check"] = {
        str(fid): {"toolpath": row.get("area_mm2"), "occ": face_area(cav.faces[fid])}
        for fid, row in listing.items()
        if isinstance(fid, int) and "area_mm2" in row
    }
    floor = cav.groups["floor"]
    tool = {"kind": a.kind, "radius": a.radius}
    if a.kind == "torus":
        tool["corner_radius"] = a.corner_radius
    job = {
        "job_id": "cavity_floor",
        "surface": {"file": str(cav.step_path), "face": floor[0]},
        "strategy": a.strategy,
        "tool": dict(tool, length=a.flute_length),
        "scallop": a.scallop,
        "lead_angle_deg": a.lead_deg,
    }
    p = plan(job, work)
    report["plan"] = {k: v for k, v in p.items() if k != "result"}
    res = p.get("result")
    if res is not None:
        report["plan"]["stats"] = res.get("stats")
        report["plan"]["within_scallop"] = res.get("within_scallop")
        report["plan"]["warnings"] = res.get("warnings")
        t = time.time()
        oracle = PartOracle(cav.solid, cav.faces, spacing=a.spacing, face_spacing=cav.oracle_spacing())
        report["oracle_build_s"] = round(time.time() - t, 1)
        assembly = ToolAssembly.from_json(dict(tool, flute_length=a.flute_length, holder=HOLDER))
        t = time.time()
        checked = check_result(oracle, res, assembly, floor)
        report["oracle_check_s"] = round(time.time() - t, 1)
        summary = checked.summary()
        summary["check_cut_by_role"] = {}
        for fid, n in summary["check_cut_by_face"].items():
            role = cav.role(int(fid)) if fid != "None" else "none"
            summary["check_cut_by_role"][role] = summary["check_cut_by_role"].get(role, 0) + n
        report["oracle"] = summary
    text = json.dumps(report, indent=1, default=str)
    if a.json:
        a.json.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
