"""Locates the `toolpath` binary the Python tests drive."""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def toolpath_bin() -> str:
    """$TOOLPATH_BIN, else the release build, else the debug build."""
    env = os.environ.get("TOOLPATH_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "toolpath"
        if p.exists():
            return str(p)
    raise RuntimeError("build the binary first: cargo build --release --bin toolpath")
