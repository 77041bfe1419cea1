"""`node.service_mapping: cyclone`: the node's services framed as rmw_cyclonedds frames them
(a 16-byte request header, client GUID half and sequence number, at the start of the payload),
so `ros2 param` over rmw_cyclonedds reaches it. The client here writes exactly that framing."""

from dataclasses import dataclass, field

import cyclonedds.idl.annotations as annotate
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import sequence, uint64, int64

from harness import rcl
from harness.process import NodeProcess
from harness.ros import Node


@annotate.final
@dataclass
class CycloneListRequest(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Request_"):
    guid: uint64 = 0
    seq: int64 = 0
    prefixes: sequence[str] = field(default_factory=list)
    depth: uint64 = 0


@annotate.final
@dataclass
class CycloneListReply(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Response_"):
    guid: uint64 = 0
    seq: int64 = 0
    result: rcl.ListParametersResult = field(default_factory=rcl.ListParametersResult)


def test_parameters_answer_requests_framed_as_rmw_cyclonedds_frames_them():
    proc = NodeProcess(ros_args=["-r", "__node:=tp_cyclone", "-p", "node.service_mapping:=cyclone",
                                 "-p", "node.verify:=false"])
    peer = None
    try:
        peer = Node("cyclone_mapping_test", domain_id=proc.domain_id)
        client = rcl.ServiceClient(peer._dp, "/tp_cyclone", "list_parameters", CycloneListRequest,
                                   CycloneListReply)
        client.wait_for_service()
        for seq in (1, 2):
            reply = client.call(CycloneListRequest(guid=0x1122334455667788, seq=seq))
            # The header comes back as sent: that is how rmw_cyclonedds pairs a reply with its request.
            assert (reply.guid, reply.seq) == (0x1122334455667788, seq), reply
            names = list(reply.result.names)
            assert "node.service_mapping" in names and "node.workers" in names, names
    finally:
        if peer is not None:
            peer.destroy_node()
        proc.stop()
