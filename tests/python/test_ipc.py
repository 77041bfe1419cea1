"""A Python consumer of the iceoryx2 toolpath service (payload layout in docs/formats.md)."""

import ctypes
import gc
import json
import math
import os
import subprocess
import time
from pathlib import Path

import iceoryx2 as iox2
import pytest

from toolpath_bin import toolpath_bin


class ToolpathHeader(ctypes.LittleEndianStructure):
    _fields_ = [
        ("magic", ctypes.c_char * 4),
        ("version", ctypes.c_uint32),
        ("header_size", ctypes.c_uint32),
        ("point_size", ctypes.c_uint32),
        ("point_count", ctypes.c_uint64),
        ("pass_count", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("path_length_mm", ctypes.c_double),
        ("compute_ms", ctypes.c_double),
        ("max_scallop_mm", ctypes.c_double),
        ("job_id", ctypes.c_char * 64),
        ("strategy", ctypes.c_char * 32),
        ("machine", ctypes.c_char * 16),
        ("reserved", ctypes.c_uint8 * 80),
    ]


class IpcPoint(ctypes.LittleEndianStructure):
    _fields_ = [
        ("cc", ctypes.c_double * 3),
        ("cl", ctypes.c_double * 3),
        ("axis", ctypes.c_double * 3),
        ("uv", ctypes.c_double * 2),
        ("strip_width", ctypes.c_double),
        ("pass_index", ctypes.c_uint32),
        ("region", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]


def make_result(n_passes=4, n_points=500):
    passes = []
    for k in range(n_passes):
        pts = []
        for i in range(n_points):
            pts.append({
                "cc": [float(i), 10.0 * k, 0.1 * i],
                "cl": [float(i), 10.0 * k, 0.1 * i + 2.0],
                "axis": [0.0, 0.0, 1.0],
                "uv": [i / n_points, k / n_passes],
                **({"strip_width": 2.0 + k} if k % 2 == 0 else {}),
            })
        passes.append({"region": k // 2, "points": pts})
    return {
        "job_id": "py_ipc_job",
        "strategy": "iso_parametric",
        "machine": "mill5",
        "passes": passes,
        "stats": {"path_length_mm": 42.0, "passes": n_passes, "max_scallop_mm": None, "compute_ms": 1.5},
    }


def prefix_files(prefix):
    out = []
    for root in ("/dev/shm", "/tmp/iceoryx2"):
        for dirpath, _, files in os.walk(root):
            out += [os.path.join(dirpath, f) for f in files if prefix in f]
    return out


def test_python_consumer_reads_toolpath(tmp_path):
    assert ctypes.sizeof(ToolpathHeader) == 256
    assert ctypes.sizeof(IpcPoint) == 112
    result = make_result()
    path = tmp_path / "result.json"
    path.write_text(json.dumps(result))
    prefix = f"tpy{os.getpid()}_"
    service = "toolpath_planner/pytest/toolpath"

    config = iox2.config.default()
    config.global_cfg.prefix = iox2.FileName.new(prefix)
    node = iox2.NodeBuilder.new().config(config).create(iox2.ServiceType.Ipc)
    svc = (node.service_builder(iox2.ServiceName.new(service))
           .publish_subscribe(iox2.Slice[ctypes.c_uint8]).open_or_create())
    sub = svc.subscriber_builder().create()

    proc = subprocess.Popen(
        [toolpath_bin(), "ipc-publish", str(path), "--service", service, "--prefix", prefix,
         "--repeat", "20", "--interval-ms", "50"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        payload = None
        deadline = time.time() + 30
        while payload is None and time.time() < deadline:
            sample = sub.receive()
            if sample is not None:
                s = sample.payload()
                payload = ctypes.string_at(s.data_ptr, s.number_of_elements)
                # The slice holds the sample, the sample the subscriber: release both.
                del s, sample
            else:
                time.sleep(0.01)
        assert payload is not None, "no toolpath within 30 s"
    finally:
        # The publisher ends by itself after its repeats (a clean exit removes its files).
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, proc.stderr.read().decode()

    head = ToolpathHeader.from_buffer_copy(payload[:256])
    assert head.magic == b"TPTH" and head.version == 1
    assert head.point_count == 4 * 500 and head.pass_count == 4
    assert head.job_id.decode() == "py_ipc_job"
    assert head.strategy.decode() == "iso_parametric"
    assert head.machine.decode() == "mill5"
    assert head.path_length_mm == 42.0
    assert math.isnan(head.max_scallop_mm)
    assert len(payload) == 256 + 112 * head.point_count
    points = (IpcPoint * head.point_count).from_buffer_copy(payload[256:])
    k = 0
    for pi, p in enumerate(result["passes"]):
        for i, q in enumerate(p["points"]):
            got = points[k]
            assert list(got.cc) == q["cc"] and list(got.cl) == q["cl"] and list(got.uv) == q["uv"]
            assert got.pass_index == pi and got.region == p["region"]
            assert got.flags == (1 if i == 0 else 0)
            if "strip_width" in q:
                assert got.strip_width == q["strip_width"]
            else:
                assert math.isnan(got.strip_width)
            k += 1

    sample = None
    del sub, svc, node, sample
    gc.collect()
    left = [f for f in prefix_files(prefix) if not f.endswith(".global_mgmt")]
    assert not left, f"iceoryx2 files left behind: {left}"
    for f in prefix_files(prefix):
        os.remove(f)
