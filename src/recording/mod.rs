//! MCAP (rosbag2) recording and replay: not implemented yet.
