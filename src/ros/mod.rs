//! The ROS 2 node (ros2-client): a thin adapter over `pipeline`. Not implemented yet.
