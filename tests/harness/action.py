"""The node's PlanToolpath action and service for a Cyclone DDS peer without
rclpy, as rmw_cyclonedds lays an action out on DDS:

- services ``<action>/_action/send_goal``, ``get_result`` (types
  ``toolpath_msgs::action::dds_::PlanToolpath_SendGoal_Request_`` ...) and
  ``cancel_goal`` (``action_msgs::srv::dds_::CancelGoal_Request_``);
- topic ``rt/<action>/_action/feedback``
  (``toolpath_msgs::action::dds_::PlanToolpath_FeedbackMessage_``).

The types come from msg/action/PlanToolpath.action and msg/srv/PlanToolpath.srv;
the action_msgs and unique_identifier_msgs wrappers are written out here.
Requests go through ``rcl.ServiceClient`` (no request header: the node's
"enhanced" service mapping).
"""

import os
import time
import uuid

from cyclonedds.idl import types as t

from . import msgs, rcl

PKG = "toolpath_msgs"
Goal, Result, Feedback = msgs.sections(
    os.path.join(msgs.ROOT, "msg", "action", "PlanToolpath.action"), PKG, "action", "PlanToolpath",
    ["Goal", "Result", "Feedback"])
Request, Response = msgs.sections(
    os.path.join(msgs.ROOT, "msg", "srv", "PlanToolpath.srv"), PKG, "srv", "PlanToolpath",
    ["Request", "Response"])

Time = msgs.get("builtin_interfaces/Time")
UUID = msgs.struct("UUID", "unique_identifier_msgs::msg::dds_::UUID_",
                   [("uuid", t.array[t.uint8, 16], lambda: [0] * 16)])
GoalInfo = msgs.struct("GoalInfo", "action_msgs::msg::dds_::GoalInfo_",
                       [("goal_id", UUID, UUID), ("stamp", Time, Time)])


def _action_type(part):
    return "%s::action::dds_::PlanToolpath_%s_" % (PKG, part)


SendGoal_Request = msgs.struct("SendGoal_Request", _action_type("SendGoal_Request"),
                               [("goal_id", UUID, UUID), ("goal", Goal, Goal)])
SendGoal_Response = msgs.struct("SendGoal_Response", _action_type("SendGoal_Response"),
                                [("accepted", bool, bool), ("stamp", Time, Time)])
GetResult_Request = msgs.struct("GetResult_Request", _action_type("GetResult_Request"),
                                [("goal_id", UUID, UUID)])
GetResult_Response = msgs.struct("GetResult_Response", _action_type("GetResult_Response"),
                                 [("status", t.int8, int), ("result", Result, Result)])
FeedbackMessage = msgs.struct("FeedbackMessage", _action_type("FeedbackMessage"),
                              [("goal_id", UUID, UUID), ("feedback", Feedback, Feedback)])
CancelGoal_Request = msgs.struct("CancelGoal_Request", "action_msgs::srv::dds_::CancelGoal_Request_",
                                 [("goal_info", GoalInfo, GoalInfo)])
CancelGoal_Response = msgs.struct("CancelGoal_Response", "action_msgs::srv::dds_::CancelGoal_Response_",
                                  [("return_code", t.int8, int), ("goals_canceling", t.sequence[GoalInfo], list)])

# action_msgs/GoalStatus
STATUS_ACCEPTED, STATUS_EXECUTING = 1, 2
STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6
# action_msgs/srv/CancelGoal return codes
CANCEL_NONE, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = 0, 1, 2, 3


def new_goal_id():
    return UUID(uuid=list(uuid.uuid4().bytes))


class ActionClient:
    """A PlanToolpath client of the action ``plan_toolpath`` in namespace `ns` (e.g. /cell)."""

    def __init__(self, dp, ns, name="plan_toolpath"):
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        base = ns.rstrip("/") + "/" + name + "/_action"
        self.send_goal = rcl.ServiceClient(dp, base, "send_goal", SendGoal_Request, SendGoal_Response)
        self.get_result = rcl.ServiceClient(dp, base, "get_result", GetResult_Request, GetResult_Response)
        self.cancel_goal = rcl.ServiceClient(dp, base, "cancel_goal", CancelGoal_Request, CancelGoal_Response)
        topic = "rt/" + base.strip("/") + "/feedback"
        self.feedback_reader = DataReader(dp, Topic(dp, topic, FeedbackMessage), qos=rcl._service_qos())
        self.feedback = []

    def wait(self, timeout=20.0):
        for c in (self.send_goal, self.get_result, self.cancel_goal):
            c.wait_for_service(timeout)
        deadline = time.monotonic() + timeout
        while not self.feedback_reader.get_matched_publications():
            assert time.monotonic() < deadline, "the action's feedback publisher was not discovered"
            time.sleep(0.05)

    def send(self, goal):
        """(goal id, accepted)."""
        goal_id = new_goal_id()
        r = self.send_goal.call(SendGoal_Request(goal_id=goal_id, goal=goal))
        return goal_id, r.accepted

    def result(self, goal_id, timeout=120.0):
        """(action status, PlanToolpath result) once the goal has ended."""
        r = self.get_result.call(GetResult_Request(goal_id=goal_id), timeout=timeout)
        return r.status, r.result

    def cancel(self, goal_id):
        return self.cancel_goal.call(CancelGoal_Request(goal_info=GoalInfo(goal_id=goal_id)))

    def feedback_of(self, goal_id):
        """The feedback received so far for `goal_id`: [(stage, progress)]."""
        self.feedback += self.feedback_reader.take(N=1000)
        return [(m.feedback.stage, m.feedback.progress) for m in self.feedback
                if list(m.goal_id.uuid) == list(goal_id.uuid)]


class PlanClient:
    """A client of the service ``plan_toolpath`` in namespace `ns`."""

    def __init__(self, dp, ns, name="plan_toolpath"):
        self.client = rcl.ServiceClient(dp, ns.rstrip("/"), name, Request, Response)

    def wait(self, timeout=20.0):
        self.client.wait_for_service(timeout)

    def call(self, request, timeout=120.0):
        return self.client.call(request, timeout=timeout)
