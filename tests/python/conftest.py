import os
import sys

import pytest

sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..")))

from harness.client import Client  # noqa: E402
from harness.process import NodeProcess  # noqa: E402


@pytest.fixture(scope="module")
def node():
    """`toolpath node` with the default config on a fresh random domain."""
    proc = NodeProcess()
    yield proc
    proc.stop()


@pytest.fixture(scope="module")
def client(node):
    c = Client(node.domain_id)
    c.wait_for_node()
    yield c
    c.close()
