"""A user-space Ethernet relay between two interfaces that loses, duplicates,
reorders and delays frames (this kernel has no netem, tc actions or
nftables, docs in tests/harness/netns.py).

Run as root inside the relay's network namespace:

    python -m harness.relay IF_A IF_B --loss 0.3 --dup 0.05 --reorder 0.3 \
        --delay-ms 5 20 --seed 7 --stats STATS.json

Every frame received on one interface goes out on the other, after a delay
drawn from [delay_min, delay_max] ms; a reordered frame waits a further
delay_max so that frames after it overtake it; a lost frame is not sent; a
duplicated one is sent twice. ARP and multicast are frames like any other,
so the two sides see one Ethernet segment. On SIGTERM the counts go to the
stats file as JSON.
"""

import argparse
import heapq
import json
import os
import random
import select
import signal
import socket
import time

ETH_P_ALL = 0x0003
PACKET_OUTGOING = 4


class Impairment:
    """What happens to each frame; a seeded RNG makes a run repeatable."""

    def __init__(self, loss=0.0, dup=0.0, reorder=0.0, delay_ms=(0.0, 0.0), seed=0):
        self.loss, self.dup, self.reorder = loss, dup, reorder
        self.delay_ms = delay_ms
        self.rng = random.Random(seed)

    def fate(self):
        """The send delays (seconds) of one frame: none (lost), one or two."""
        r = self.rng
        if r.random() < self.loss:
            return [], "lost"
        lo, hi = self.delay_ms
        d = r.uniform(lo, hi) / 1000.0
        kind = "passed"
        if r.random() < self.reorder:
            d += hi / 1000.0 + r.uniform(0.0, hi) / 1000.0
            kind = "reordered"
        out = [d]
        if r.random() < self.dup:
            out.append(d + r.uniform(0.0, max(hi, 1.0)) / 1000.0)
            kind = "duplicated"
        return out, kind


def without_udp_checksum(frame):
    """`frame` with its IPv4 UDP checksum set to 0 ("none", valid for UDP
    over IPv4). A veth hands a packet socket frames whose checksum the
    "hardware" was to fill in (checksum offload); sent on as they are, the
    receiver would drop them as corrupt."""
    if len(frame) < 42 or frame[12:14] != b"\x08\x00" or frame[23] != 17:
        return frame
    if (frame[20] & 0x1F) or frame[21]:  # a later fragment carries no UDP header
        return frame
    at = 14 + (frame[14] & 0x0F) * 4 + 6
    return frame[:at] + b"\x00\x00" + frame[at + 2 :]


def raw_socket(ifname):
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    s.bind((ifname, 0))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 8 << 20)
    s.setblocking(False)
    return s


def relay(if_a, if_b, impairment, stats_path, stop):
    a, b = raw_socket(if_a), raw_socket(if_b)
    other = {a.fileno(): b, b.fileno(): a}
    pending = []  # (due, order, socket, frame)
    order = 0
    counts = {"received": 0, "lost": 0, "passed": 0, "reordered": 0, "duplicated": 0, "sent": 0, "send_errors": 0}
    while not stop["now"]:
        now = time.monotonic()
        timeout = max(0.0, pending[0][0] - now) if pending else 0.2
        try:
            ready, _, _ = select.select([a, b], [], [], min(timeout, 0.2))
        except InterruptedError:
            continue
        for s in ready:
            while True:
                try:
                    frame, addr = s.recvfrom(65535)
                except BlockingIOError:
                    break
                if addr[2] == PACKET_OUTGOING:
                    continue
                counts["received"] += 1
                frame = without_udp_checksum(frame)
                delays, kind = impairment.fate()
                counts[kind] += 1
                for d in delays:
                    order += 1
                    heapq.heappush(pending, (time.monotonic() + d, order, other[s.fileno()], frame))
        now = time.monotonic()
        while pending and pending[0][0] <= now:
            _, _, out, frame = heapq.heappop(pending)
            try:
                out.send(frame)
                counts["sent"] += 1
            except OSError:
                counts["send_errors"] += 1
    if stats_path:
        with open(stats_path + ".tmp", "w") as fh:
            json.dump(counts, fh)
        os.replace(stats_path + ".tmp", stats_path)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("if_a")
    p.add_argument("if_b")
    p.add_argument("--loss", type=float, default=0.0)
    p.add_argument("--dup", type=float, default=0.0)
    p.add_argument("--reorder", type=float, default=0.0)
    p.add_argument("--delay-ms", type=float, nargs=2, default=(0.0, 0.0))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--stats", default="")
    args = p.parse_args()
    stop = {"now": False}

    def on_term(*_):
        stop["now"] = True

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    imp = Impairment(args.loss, args.dup, args.reorder, tuple(args.delay_ms), args.seed)
    print("relaying", flush=True)
    relay(args.if_a, args.if_b, imp, args.stats, stop)


if __name__ == "__main__":
    main()
