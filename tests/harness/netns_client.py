"""A test client run in its own network namespace (see harness/netns.py):
publishes a surface, sends jobs, waits for their final statuses and writes
every status it saw to a JSON file.

    python -m harness.netns_client DOMAIN OUT.json --jobs 50 --timeout 90
"""

import argparse
import json

from harness.client import Client, job, quadratic_surface, tool
from harness.faults import small_job_ids


def main():
    p = argparse.ArgumentParser()
    p.add_argument("domain", type=int)
    p.add_argument("out")
    p.add_argument("--jobs", type=int, default=50)
    p.add_argument("--timeout", type=float, default=90.0)
    p.add_argument("--prefix", default="lossy")
    args = p.parse_args()
    c = Client(args.domain)
    c.wait_for_node(timeout=args.timeout / 2)
    c.send_surface(quadratic_surface("lossy_surface", 0, 40, -15, 15, ky=0.01))
    ids = small_job_ids(args.prefix, args.jobs)
    for j in ids:
        c.send_job(job(j, "lossy_surface", "iso_parametric", tool("ball", radius=3.0), scallop=0.1))
    done = c.node.spin_until(lambda: all(c.final(j) for j in ids), args.timeout)
    # A little longer, to catch a second final status.
    c.node.spin_until(lambda: False, 1.0)
    seen = {
        j: [[s.state, s.header.stamp.sec, s.header.stamp.nanosec, s.message] for s in c.statuses.get(j, [])]
        for j in ids
    }
    with open(args.out, "w") as fh:
        json.dump({"all_final": bool(done), "statuses": seen}, fh)
    c.close()


if __name__ == "__main__":
    main()
