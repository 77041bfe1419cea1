"""A small rclpy-shaped layer: ``Node`` with ``create_publisher`` and
``create_subscription``, ``spin_once`` and ``spin_until``.

With rclpy importable (a sourced ROS 2 install with toolpath_msgs built by
colcon) it is a thin wrapper over rclpy. Otherwise it talks DDS directly with
Cyclone DDS, exactly as rmw_cyclonedds would: topic ``rt/<namespace>/<name>``,
type ``pkg::msg::dds_::Type_``, XCDR1 payloads. DDS stays on loopback: the
Cyclone configuration below is installed unless CYCLONEDDS_URI is already set.
"""

import os
import time

LOOPBACK_URI = (
    '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo"/>'
    "</Interfaces></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>100</MaxAutoParticipantIndex>"
    "</Discovery></Domain></CycloneDDS>"
)
os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK_URI)

try:  # pragma: no cover - only with a ROS 2 installation
    import rclpy  # noqa: F401
    import rclpy.qos as _rq
    import toolpath_msgs.msg  # noqa: F401

    HAVE_RCLPY = not os.environ.get("TOOLPATH_HARNESS_NO_RCLPY")
except ImportError:
    HAVE_RCLPY = False


class QoSProfile:
    """The knobs the node's topics use (see README: Topics)."""

    def __init__(self, depth=10, reliable=True, transient_local=False, keep_all=False):
        self.depth = depth
        self.reliable = reliable
        self.transient_local = transient_local
        self.keep_all = keep_all


# The node's QoS per topic (the contract in README.md).
QOS_SHAPES = QoSProfile(depth=100, transient_local=True)
QOS_JOB = QoSProfile(depth=100)
QOS_STATUS = QoSProfile(depth=1000, transient_local=True)
QOS_RESULTS = QoSProfile(depth=10, transient_local=True)
# What the tests' own readers use: keep everything they are sent.
QOS_READ_ALL = QoSProfile(keep_all=True, transient_local=True)


def _cyclone_qos(q):
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    policies = [
        Policy.Reliability.Reliable(duration(seconds=5)) if q.reliable else Policy.Reliability.BestEffort,
        Policy.Durability.TransientLocal if q.transient_local else Policy.Durability.Volatile,
        Policy.History.KeepAll if q.keep_all else Policy.History.KeepLast(q.depth),
    ]
    if q.keep_all:
        policies.append(Policy.ResourceLimits(max_samples=-1, max_instances=-1, max_samples_per_instance=-1))
    return Qos(*policies)


def dds_topic_name(namespace, name):
    ns = namespace.strip("/")
    return "rt/" + (ns + "/" if ns else "") + name


class _CyclonePublisher:
    def __init__(self, writer):
        self._writer = writer

    def publish(self, msg):
        self._writer.write(msg)

    def get_subscription_count(self):
        return len(self._writer.get_matched_subscriptions())


class _CycloneSubscription:
    def __init__(self, reader, callback):
        self.reader = reader
        self.callback = callback

    def get_publisher_count(self):
        return len(self.reader.get_matched_publications())


class Node:
    """rclpy.node.Node look-alike over Cyclone DDS (or rclpy itself)."""

    def __init__(self, name, namespace="/", domain_id=None):
        self.namespace = namespace
        if domain_id is None:
            domain_id = int(os.environ.get("ROS_DOMAIN_ID", "0"))
        self.domain_id = domain_id
        self._subs = []
        if HAVE_RCLPY:  # pragma: no cover
            import rclpy

            self._ctx = rclpy.Context()
            rclpy.init(context=self._ctx, domain_id=domain_id)
            self._node = rclpy.create_node(name, namespace=namespace, context=self._ctx)
            self._executor = rclpy.executors.SingleThreadedExecutor(context=self._ctx)
            self._executor.add_node(self._node)
        else:
            from cyclonedds.core import WaitSet
            from cyclonedds.domain import DomainParticipant

            self._dp = DomainParticipant(domain_id)
            self._waitset = WaitSet(self._dp)
            self._topics = {}

    # -- rclpy-style API -------------------------------------------------
    def create_publisher(self, msg_type, topic, qos):
        if HAVE_RCLPY:  # pragma: no cover
            return self._node.create_publisher(_rclpy_type(msg_type), topic, _rclpy_qos(qos))
        from cyclonedds.pub import DataWriter

        return _CyclonePublisher(DataWriter(self._dp, self._topic(msg_type, topic), qos=_cyclone_qos(qos)))

    def create_subscription(self, msg_type, topic, callback, qos):
        if HAVE_RCLPY:  # pragma: no cover
            return self._node.create_subscription(_rclpy_type(msg_type), topic, callback, _rclpy_qos(qos))
        from cyclonedds.core import ReadCondition, SampleState, ViewState, InstanceState
        from cyclonedds.sub import DataReader

        reader = DataReader(self._dp, self._topic(msg_type, topic), qos=_cyclone_qos(qos))
        cond = ReadCondition(reader, SampleState.NotRead | ViewState.Any | InstanceState.Any)
        self._waitset.attach(cond)
        sub = _CycloneSubscription(reader, callback)
        sub.condition = cond
        self._subs.append(sub)
        return sub

    def spin_once(self, timeout_sec=0.1):
        """Delivers what has arrived to the callbacks; waits up to timeout_sec."""
        if HAVE_RCLPY:  # pragma: no cover
            self._executor.spin_once(timeout_sec=timeout_sec)
            return
        from cyclonedds.util import duration

        self._waitset.wait(duration(microseconds=int(timeout_sec * 1e6)))
        for sub in self._subs:
            while True:
                samples = sub.reader.take(N=256)
                if not samples:
                    break
                for s in samples:
                    sub.callback(s)

    def spin_until(self, predicate, timeout_sec):
        """Spins until predicate() is true; returns its final value."""
        deadline = time.monotonic() + timeout_sec
        while not predicate():
            left = deadline - time.monotonic()
            if left <= 0:
                return predicate()
            self.spin_once(min(0.05, left))
        return True

    def destroy_node(self):
        if HAVE_RCLPY:  # pragma: no cover
            self._node.destroy_node()
            self._ctx.try_shutdown()
            return
        for sub in self._subs:
            self._waitset.detach(sub.condition)
        self._subs = []
        self._topics = {}
        self._dp = None

    # -- internals ------------------------------------------------------------
    def _topic(self, msg_type, name):
        from cyclonedds.topic import Topic

        dds_name = dds_topic_name(self.namespace, name)
        if dds_name not in self._topics:
            self._topics[dds_name] = Topic(self._dp, dds_name, msg_type)
        return self._topics[dds_name]


def _rclpy_type(msg_type):  # pragma: no cover
    import importlib

    pkg, name = msg_type.ros_name.split("/")
    return getattr(importlib.import_module(pkg + ".msg"), name)


def _rclpy_qos(q):  # pragma: no cover
    return _rq.QoSProfile(
        depth=q.depth,
        reliability=_rq.ReliabilityPolicy.RELIABLE if q.reliable else _rq.ReliabilityPolicy.BEST_EFFORT,
        durability=_rq.DurabilityPolicy.TRANSIENT_LOCAL if q.transient_local else _rq.DurabilityPolicy.VOLATILE,
        history=_rq.HistoryPolicy.KEEP_ALL if q.keep_all else _rq.HistoryPolicy.KEEP_LAST,
    )
