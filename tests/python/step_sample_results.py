"""The docs/results.md table "STEP samples": every surface strategy on the
freeform face of each STEP sample, planned and verified by `toolpath plan`,
and the import time of each part (`toolpath import --list`, best of 3).

    cargo build --release --bin toolpath
    python3 tests/python/step_sample_results.py [TOOLPATH_BIN]
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = sys.argv[1] if len(sys.argv) > 1 else "target/release/toolpath"
SAMPLES = ("step_freeform", "step_multi_face")
STRATEGIES = {
    "tensor_regions": {"tool": {"kind": "ball", "radius": 5.0}, "scallop": 0.05},
    "iso_scallop": {"tool": {"kind": "ball", "radius": 5.0}, "scallop": 0.05},
    "iso_parametric": {"tool": {"kind": "ball", "radius": 5.0}, "scallop": 0.05},
    "mpec": {"tool": {"kind": "torus", "radius": 8.0, "corner_radius": 2.0}, "tolerance": 0.05, "feed_direction": "u"},
    "belt_iso_parametric": {"tool": {"kind": "belt", "width": 10.0, "wheel_radius": 50.0}, "scallop": 0.1},
    "belt_iso_planar": {"tool": {"kind": "belt", "width": 10.0, "wheel_radius": 50.0}, "scallop": 0.1},
}


def run(*args):
    return subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)


def main():
    out = Path(tempfile.mkdtemp())
    print("| sample | strategy (tool) | length mm | passes | max scallop mm | h | plan s |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    imports = {}
    for name in SAMPLES:
        part = out / f"{name}.step"
        run("sample", name, "-o", part).check_returncode()
        best = None
        for _ in range(3):
            t0 = time.perf_counter()
            r = run("import", part, "--list")
            best = min(best or 1e9, time.perf_counter() - t0)
        r.check_returncode()
        faces = [l.split() for l in r.stdout.splitlines() if l.strip().startswith("#")]
        imports[name] = (best, len(faces))
        face = int(faces[0][0][1:])
        for strategy, params in STRATEGIES.items():
            job = {"job_id": f"{name}_{strategy}", "surface": {"file": part.name, "face": face}, "strategy": strategy, **params}
            (out / "job.json").write_text(json.dumps(job))
            t0 = time.perf_counter()
            r = run("plan", out / "job.json", "-o", out / "result.json")
            dt = time.perf_counter() - t0
            if r.returncode not in (0, 4):
                print(f"| {name} | {strategy} | failed: {r.stderr.strip()} |")
                continue
            st = json.loads((out / "result.json").read_text())["stats"]
            h = params.get("scallop", params.get("tolerance"))
            scallop = st.get("max_scallop_mm")
            scallop = f"{scallop:.5f}" if scallop is not None else "-"
            tool = params["tool"]["kind"]
            print(f"| {name} | {strategy} ({tool}) | {st['path_length_mm']:.1f} | {st['passes']} | {scallop} | {h} | {dt:.2f} |")
    print()
    for name, (t, n) in imports.items():
        print(f"import --list {name}: {n} face(s), {t * 1e3:.0f} ms (whole process, best of 3)")


if __name__ == "__main__":
    main()
