"""ROS 2's rcl_interfaces on the wire, for a Cyclone DDS peer without rclpy:
the parameter services' request and response types, the parameter types and
rcl_interfaces/Log of /rosout, named as rmw_cyclonedds names them.

Services follow the ROS 2 topic layout: requests on ``rq/<node>/<service>Request``,
replies on ``rr/<node>/<service>Reply``, types ``pkg::srv::dds_::Service_Request_``
and ``..._Response_``. ros2-client's parameter services use the "enhanced"
request/reply mapping (the request id travels as the DDS related-sample-identity,
as with rmw_fastrtps), so the payload carries no request header; this client
sends one request at a time and takes the reply that follows it.
"""

import time
from dataclasses import dataclass, field

import cyclonedds.idl.annotations as annotate
from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int64, sequence, uint8, uint32, uint64
from cyclonedds.util import duration

from . import msgs

# rcl_interfaces/ParameterType
NOT_SET, BOOL, INTEGER, DOUBLE, STRING = 0, 1, 2, 3, 4
BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = 5, 6, 7, 8, 9

# rcl_interfaces/Log levels
DEBUG, INFO, WARN, ERROR, FATAL = 10, 20, 30, 40, 50


@annotate.final
@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: uint8 = 0
    bool_value: bool = False
    integer_value: int64 = 0
    double_value: float64 = 0.0
    string_value: str = ""
    byte_array_value: sequence[uint8] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[int64] = field(default_factory=list)
    double_array_value: sequence[float64] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)


@annotate.final
@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@annotate.final
@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool = False
    reason: str = ""


@annotate.final
@dataclass
class ListParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: sequence[str] = field(default_factory=list)
    prefixes: sequence[str] = field(default_factory=list)


@annotate.final
@dataclass
class ListParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Request_"):
    prefixes: sequence[str] = field(default_factory=list)
    depth: uint64 = 0


@annotate.final
@dataclass
class ListParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Response_"):
    result: ListParametersResult = field(default_factory=ListParametersResult)


@annotate.final
@dataclass
class GetParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Request_"):
    names: sequence[str] = field(default_factory=list)


@annotate.final
@dataclass
class GetParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Response_"):
    values: sequence[ParameterValue] = field(default_factory=list)


@annotate.final
@dataclass
class SetParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Request_"):
    parameters: sequence[Parameter] = field(default_factory=list)


@annotate.final
@dataclass
class SetParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Response_"):
    results: sequence[SetParametersResult] = field(default_factory=list)


@annotate.final
@dataclass
class FloatingPointRange(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float64 = 0.0
    to_value: float64 = 0.0
    step: float64 = 0.0


@annotate.final
@dataclass
class IntegerRange(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: int64 = 0
    to_value: int64 = 0
    step: uint64 = 0


@annotate.final
@dataclass
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str = ""
    type: uint8 = 0
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    floating_point_range: sequence[FloatingPointRange, 1] = field(default_factory=list)
    integer_range: sequence[IntegerRange, 1] = field(default_factory=list)


@annotate.final
@dataclass
class DescribeParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Request_"):
    names: sequence[str] = field(default_factory=list)


@annotate.final
@dataclass
class DescribeParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Response_"):
    descriptors: sequence[ParameterDescriptor] = field(default_factory=list)


@annotate.final
@dataclass
class Log(IdlStruct, typename="rcl_interfaces::msg::dds_::Log_"):
    stamp: msgs.Time = field(default_factory=msgs.Time)
    level: uint8 = 0
    name: str = ""
    msg: str = ""
    file: str = ""
    function: str = ""
    line: uint32 = 0


def value(v):
    """A Python value as a ParameterValue (bool, int, float, str, or a list of one)."""
    if isinstance(v, bool):
        return ParameterValue(type=BOOL, bool_value=v)
    if isinstance(v, int):
        return ParameterValue(type=INTEGER, integer_value=v)
    if isinstance(v, float):
        return ParameterValue(type=DOUBLE, double_value=v)
    if isinstance(v, str):
        return ParameterValue(type=STRING, string_value=v)
    raise TypeError("no parameter type for %r" % (v,))


def python(p):
    """A ParameterValue as a Python value (None when not set)."""
    return {
        NOT_SET: lambda: None,
        BOOL: lambda: p.bool_value,
        INTEGER: lambda: p.integer_value,
        DOUBLE: lambda: p.double_value,
        STRING: lambda: p.string_value,
        BYTE_ARRAY: lambda: list(p.byte_array_value),
        BOOL_ARRAY: lambda: list(p.bool_array_value),
        INTEGER_ARRAY: lambda: list(p.integer_array_value),
        DOUBLE_ARRAY: lambda: list(p.double_array_value),
        STRING_ARRAY: lambda: list(p.string_array_value),
    }[p.type]()


def _service_qos():
    # rclpy's services_default: reliable, volatile, keep-last 10.
    return Qos(
        Policy.Reliability.Reliable(duration(seconds=5)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )


class ServiceClient:
    """One ROS 2 service client (request writer, reply reader) on participant `dp`."""

    def __init__(self, dp, node_fq, service, request_type, response_type):
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        base = node_fq.strip("/") + "/" + service
        self.writer = DataWriter(dp, Topic(dp, "rq/%sRequest" % base, request_type), qos=_service_qos())
        self.reader = DataReader(dp, Topic(dp, "rr/%sReply" % base, response_type), qos=_service_qos())
        self.service = base

    def wait_for_service(self, timeout=20.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.writer.get_matched_subscriptions() and self.reader.get_matched_publications():
                return
            time.sleep(0.05)
        raise AssertionError("service %s not discovered within %s s" % (self.service, timeout))

    def call(self, request, timeout=10.0, resend_after=None):
        """The reply to `request`, waiting up to `timeout` s.

        Discovery is not symmetric: our reader may see the server's reply
        writer before that writer has matched our reader, and a volatile
        reply sent in that window reaches nobody. `resend_after` (seconds)
        sends the request again when no reply came by then; only for
        idempotent requests (parameter list/get/describe/set), never for a
        goal, which the server must see once.
        """
        self.reader.take(N=100)  # nothing stale is taken for this reply
        self.writer.write(request)
        start = time.monotonic()
        deadline = start + timeout
        next_send = start + resend_after if resend_after else None
        while time.monotonic() < deadline:
            got = self.reader.take(N=1)
            if got:
                return got[0]
            if next_send is not None and time.monotonic() >= next_send:
                self.writer.write(request)
                next_send += resend_after
            time.sleep(0.02)
        raise AssertionError("no reply from %s within %s s" % (self.service, timeout))


# Parameter services answer the same request the same way twice: resend
# after 2 s of silence, give up after 20 s.
IDEMPOTENT = {"timeout": 20.0, "resend_after": 2.0}


class ParameterClient:
    """`ros2 param list/get/set` of the node `node_fq` (e.g. /cell_b/tp)."""

    def __init__(self, dp, node_fq):
        self.list_client = ServiceClient(dp, node_fq, "list_parameters", ListParameters_Request, ListParameters_Response)
        self.get_client = ServiceClient(dp, node_fq, "get_parameters", GetParameters_Request, GetParameters_Response)
        self.set_client = ServiceClient(dp, node_fq, "set_parameters", SetParameters_Request, SetParameters_Response)
        self.describe_client = ServiceClient(dp, node_fq, "describe_parameters", DescribeParameters_Request,
                                             DescribeParameters_Response)

    def wait(self, timeout=20.0):
        for c in (self.list_client, self.get_client, self.set_client, self.describe_client):
            c.wait_for_service(timeout)

    def list(self):
        return list(self.list_client.call(ListParameters_Request(prefixes=[], depth=0), **IDEMPOTENT).result.names)

    def get(self, *names):
        r = self.get_client.call(GetParameters_Request(names=list(names)), **IDEMPOTENT)
        return [python(v) for v in r.values]

    def describe(self, *names):
        """`ros2 param describe`: one ParameterDescriptor per name."""
        return list(self.describe_client.call(DescribeParameters_Request(names=list(names)), **IDEMPOTENT).descriptors)

    def set(self, name, v):
        """(successful, reason) of setting one parameter."""
        r = self.set_client.call(SetParameters_Request(parameters=[Parameter(name=name, value=value(v))]),
                                 **IDEMPOTENT)
        assert len(r.results) == 1, r
        return r.results[0].successful, r.results[0].reason
