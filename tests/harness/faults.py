"""What the fault tests share: the jobs they send, the statuses a client saw
reduced to what identifies them, the statuses a bag holds, and toolpaths
compared without what differs from run to run (stamps, timings)."""

import copy
import glob
import os
import subprocess

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

FINAL_STATES = (2, 3, 4, 5)


def small_job_ids(prefix, n):
    return ["%s_%03d" % (prefix, k) for k in range(n)]


def status_key(s):
    """What identifies one status message: its job, state, stamp and text."""
    return (s.job_id, s.state, s.header.stamp.sec, s.header.stamp.nanosec, s.message)


def distinct_finals(statuses):
    """The final statuses of a job, each message once (a node that restarts
    may publish a final again, as the same message)."""
    out = []
    for s in statuses:
        if s.state in FINAL_STATES and status_key(s) not in [status_key(o) for o in out]:
            out.append(s)
    return out


def reindex(toolpath, bag_dir):
    """`toolpath bag reindex BAG` (the bag of a killed node)."""
    r = subprocess.run([toolpath, "bag", "reindex", str(bag_dir)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, "bag reindex %s: %s %s" % (bag_dir, r.stdout, r.stderr)


def bag_statuses(directory):
    """The keys of every job_status message in the bags under `directory`."""
    keys = set()
    for path in sorted(glob.glob(os.path.join(str(directory), "*", "*.mcap"))):
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _, channel, _, msg in reader.iter_decoded_messages(topics=["/job_status"]):
                keys.add((msg.job_id, msg.state, msg.header.stamp.sec, msg.header.stamp.nanosec, msg.message))
    return keys


def comparable(toolpath):
    """A toolpath message with its stamp and timings cleared."""
    t = copy.deepcopy(toolpath)
    t.header.stamp.sec = 0
    t.header.stamp.nanosec = 0
    t.stats.compute_ms = 0.0
    kept = [(n, v) for n, v in zip(t.stats.extra_names, t.stats.extra_values) if not n.endswith("_ms")]
    t.stats.extra_names = [n for n, _ in kept]
    t.stats.extra_values = [v for _, v in kept]
    return t
