"""Starting and stopping `toolpath node` as a subprocess on its own domain."""

import os
import random
import signal
import subprocess
import tempfile
import time

from .msgs import ROOT


def binary():
    """The toolpath binary: $TOOLPATH_BIN, else target/release, else target/debug."""
    env = os.environ.get("TOOLPATH_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        p = os.path.join(ROOT, "target", profile, "toolpath")
        if os.path.exists(p):
            return p
    raise RuntimeError("no toolpath binary: run `cargo build --release` first")


def random_domain():
    """A fresh domain id (1..200) so concurrent runs do not see each other."""
    return random.SystemRandom().randint(1, 200)


class NodeProcess:
    """`toolpath node` on `domain_id`, with `ros_args` after `--ros-args` if
    given; stop() kills it by pid and cleans up."""

    def __init__(self, domain_id=None, config_text=None, extra_env=None, ready_timeout=30.0, ros_args=None):
        self.domain_id = random_domain() if domain_id is None else domain_id
        self._tmp = tempfile.TemporaryDirectory(prefix="toolpath_node_")
        args = [binary(), "node"]
        if config_text is not None:
            cfg = os.path.join(self._tmp.name, "cell.yaml")
            with open(cfg, "w") as fh:
                fh.write(config_text)
            args += ["--config", cfg]
        if ros_args is not None:
            args += ["--ros-args"] + list(ros_args)
        env = dict(os.environ)
        env["ROS_DOMAIN_ID"] = str(self.domain_id)
        env.update(extra_env or {})
        self.log_path = os.path.join(self._tmp.name, "node.log")
        self._log = open(self.log_path, "w")
        self.proc = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=self._log, text=True)
        self.ready_line = self._wait_ready(ready_timeout)

    def _wait_ready(self, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if line.startswith("ready"):
                return line.strip()
            if not line and self.proc.poll() is not None:
                break
        self.stop()
        raise RuntimeError("node did not start: %s" % self.log())

    @property
    def pid(self):
        return self.proc.pid

    def alive(self):
        return self.proc.poll() is None

    def log(self):
        try:
            with open(self.log_path) as fh:
                return fh.read()
        except OSError:
            return ""

    def stop(self):
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        if self.proc.stdout:
            self.proc.stdout.close()
        self._log.close()
        self._tmp.cleanup()
