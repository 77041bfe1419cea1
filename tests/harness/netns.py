"""Two hosts and a lossy link between them, in network namespaces.

    node ns            relay ns                 client ns
    [veth_n 10.231.x.1] <-> [veth_rn | relay | veth_rc] <-> [veth_c 10.231.x.2]

The relay (harness/relay.py) copies Ethernet frames between its two
interfaces, losing, duplicating, reordering and delaying them as told; the
node's and the client's DDS traffic (discovery multicast included) crosses
it. The addresses exist only inside these namespaces, which the test makes
and removes. Needs root and `ip netns`; `available()` says why not.
"""

import os
import subprocess
import sys
import time

HARNESS_DIR = os.path.dirname(os.path.abspath(__file__))


def _ip(*args, check=True):
    return subprocess.run(["ip", *args], check=check, capture_output=True, text=True)


def available():
    """(True, "") when network namespaces can be made here, else (False, why)."""
    if os.geteuid() != 0:
        return False, "network namespaces need root (CI runs the tests as root)"
    name = "tp_probe_%d" % os.getpid()
    try:
        r = _ip("netns", "add", name, check=False)
    except FileNotFoundError:
        return False, "no `ip` command (iproute2) on this machine"
    if r.returncode != 0:
        return False, "`ip netns add` failed: %s" % r.stderr.strip()
    _ip("netns", "del", name, check=False)
    return True, ""


class LossyLink:
    """The three namespaces and the relay between them; `close()` removes
    them. `tag` (1..250) keeps concurrent links apart."""

    def __init__(self, tag, loss=0.0, dup=0.0, reorder=0.0, delay_ms=(0.0, 0.0), seed=0):
        self.tag = tag
        base = "tp%d_%d" % (os.getpid() % 100000, tag)
        self.node_ns, self.relay_ns, self.client_ns = base + "n", base + "r", base + "c"
        self.node_ip, self.client_ip = "10.231.%d.1" % tag, "10.231.%d.2" % tag
        self.node_if, self.client_if = "vn%d" % tag, "vc%d" % tag
        self.relay = None
        self.stats_path = "/tmp/%s_relay.json" % base
        try:
            self._make()
            self._start_relay(loss, dup, reorder, delay_ms, seed)
        except Exception:
            self.close()
            raise

    def _make(self):
        for ns in (self.node_ns, self.relay_ns, self.client_ns):
            _ip("netns", "add", ns)
            _ip("-n", ns, "link", "set", "lo", "up")
        for end, ns, ip in ((self.node_if, self.node_ns, self.node_ip), (self.client_if, self.client_ns, self.client_ip)):
            peer = "r" + end
            _ip("-n", self.relay_ns, "link", "add", peer, "type", "veth", "peer", "name", end)
            _ip("-n", self.relay_ns, "link", "set", end, "netns", ns)
            _ip("-n", self.relay_ns, "link", "set", peer, "up")
            # The relay's ends forward frames only: no addresses, no IPv6 chatter.
            _ip("-n", ns, "addr", "add", ip + "/24", "dev", end)
            _ip("-n", ns, "link", "set", end, "up")
            # DDS discovery multicast leaves through the link.
            _ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", end)

    def _start_relay(self, loss, dup, reorder, delay_ms, seed):
        args = [
            "ip", "netns", "exec", self.relay_ns, sys.executable, "-m", "harness.relay",
            "r" + self.node_if, "r" + self.client_if,
            "--loss", str(loss), "--dup", str(dup), "--reorder", str(reorder),
            "--delay-ms", str(delay_ms[0]), str(delay_ms[1]), "--seed", str(seed), "--stats", self.stats_path,
        ]
        env = dict(os.environ, PYTHONPATH=os.path.dirname(HARNESS_DIR))
        self.relay = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, text=True)
        line = self.relay.stdout.readline()
        assert line.startswith("relaying"), "the relay did not start: %r" % line

    def in_node_ns(self, args):
        return ["ip", "netns", "exec", self.node_ns] + list(args)

    def in_client_ns(self, args):
        return ["ip", "netns", "exec", self.client_ns] + list(args)

    def cyclone_uri(self):
        """Cyclone DDS on the client's link interface only."""
        return (
            '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="%s"/>'
            "</Interfaces></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
            "<MaxAutoParticipantIndex>100</MaxAutoParticipantIndex></Discovery></Domain></CycloneDDS>"
        ) % self.client_if

    def relay_stats(self):
        """The relay's counts, after close()."""
        import json

        with open(self.stats_path) as fh:
            return json.load(fh)

    def close(self):
        if self.relay is not None and self.relay.poll() is None:
            self.relay.terminate()
            try:
                self.relay.wait(10)
            except subprocess.TimeoutExpired:
                self.relay.kill()
                self.relay.wait()
        for ns in (self.node_ns, self.relay_ns, self.client_ns):
            _ip("netns", "del", ns, check=False)
        time.sleep(0.05)
