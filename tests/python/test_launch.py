"""The node's ROS 2 package and launch file, checked without a ROS install:
package.xml is read with catkin_pkg (the parser colcon and rosdep use), and
the launch file is expanded the way launch_ros builds a node's command line
(`EXE ARGS --ros-args ROS_ARGS -r __node:=NAME -r __ns:=NS --params-file F`)
and started: the node it gives must have exactly the settings of the YAML
config the params file mirrors."""

import os
import re
import tomllib
import xml.etree.ElementTree as ET

from catkin_pkg.package import parse_package

from harness.msgs import ROOT
from harness.process import NodeProcess
from harness.rcl import ParameterClient
from harness.ros import Node

LAUNCH = os.path.join(ROOT, "launch_configs", "toolpath_node.launch.xml")


def cargo():
    with open(os.path.join(ROOT, "Cargo.toml"), "rb") as fh:
        return tomllib.load(fh)


def test_package_xml_is_an_ament_cargo_package_named_like_the_crate():
    pkg = parse_package(os.path.join(ROOT, "package.xml"))
    pkg.validate()
    manifest = cargo()
    assert pkg.name == manifest["package"]["name"]
    # The root package takes its version from the workspace (`version.workspace = true`).
    version = manifest["package"]["version"]
    if version == {"workspace": True}:
        version = manifest["workspace"]["package"]["version"]
    assert pkg.version == version
    assert [e.content for e in pkg.exports if e.tagname == "build_type"] == ["ament_cargo"]
    assert {d.name for d in pkg.exec_depends} >= {"toolpath_msgs", "ros2launch"}
    # cargo ament-build copies these into share/<package>, where ros2 launch looks.
    assert manifest["package"]["metadata"]["ros"]["install_to_share"] == ["launch_configs"]
    msgs_pkg = parse_package(os.path.join(ROOT, "msg", "package.xml"))
    assert msgs_pkg.name == "toolpath_msgs"


def expand_launch(path, overrides):
    """(node element attributes, params files) of the launch file's one node,
    with $(var ...) and $(find-pkg-share toolpath_planner) substituted."""
    root = ET.parse(path).getroot()
    assert root.tag == "launch"
    values = {a.get("name"): a.get("default") for a in root.findall("arg")}
    values.update(overrides)

    def sub(text):
        # Arg defaults may hold substitutions themselves.
        for _ in range(5):
            text = text.replace("$(find-pkg-share toolpath_planner)", ROOT)
            text = re.sub(r"\$\(var (\w+)\)", lambda m: values[m.group(1)], text)
        assert "$(" not in text, text
        return text

    (node,) = root.findall("node")
    attrs = {k: sub(v) for k, v in node.attrib.items()}
    files = [sub(p.get("from")) for p in node.findall("param")]
    return attrs, files


def launch_ros_command(attrs, files):
    """The command line launch_ros runs for a <node> (executable path aside)."""
    cmd = [attrs["exec"]] + attrs.get("args", "").split()
    cmd += ["--ros-args"] + attrs.get("ros_args", "").split()
    cmd += ["-r", "__node:=" + attrs["name"], "-r", "__ns:=" + attrs["namespace"]]
    for f in files:
        cmd += ["--params-file", f]
    return cmd


def all_parameters(proc, fq):
    peer = Node("launch_test", domain_id=proc.domain_id)
    try:
        client = ParameterClient(peer._dp, fq)
        client.wait()
        names = sorted(client.list())
        return dict(zip(names, client.get(*names)))
    finally:
        peer.destroy_node()


def test_the_launch_file_starts_the_node_with_the_settings_of_cell_b(tmp_path):
    attrs, files = expand_launch(LAUNCH, {})
    assert attrs["pkg"] == cargo()["package"]["name"]
    assert attrs["exec"] in [b["name"] for b in cargo()["bin"]]
    cmd = launch_ros_command(attrs, files)
    assert cmd[:3] == ["toolpath", "node", "--ros-args"], cmd
    # Recording goes to a temporary directory instead of /var/log.
    keep_local = ["-p", "recording.directory:=" + str(tmp_path / "launched")]
    launched = NodeProcess(ros_args=cmd[3:] + keep_local)
    try:
        assert "node /cell_b/toolpath_planner on" in launched.ready_line, launched.ready_line
        got = all_parameters(launched, "/cell_b/toolpath_planner")
    finally:
        launched.stop()
    with open(os.path.join(ROOT, "launch_configs", "cell_b.yaml")) as fh:
        config = fh.read()
    keep_local = ["-p", "recording.directory:=" + str(tmp_path / "configured")]
    configured = NodeProcess(config_text=config, ros_args=keep_local)
    try:
        want = all_parameters(configured, "/cell_b/toolpath_planner")
    finally:
        configured.stop()
    del got["recording.directory"], want["recording.directory"]
    assert len(got) > 80, sorted(got)
    assert got == want
    assert got["mill5.pivot_length_mm"] == 320.0 and got["node.workers"] == 2 and got["recording.enabled"]
