"""Test harness for the toolpath_planner node: message types generated from
msg/ (``msgs``), an rclpy-shaped Node over Cyclone DDS (``ros``), the node as
a subprocess (``process``) and a client that collects a job's outputs
(``client``)."""
