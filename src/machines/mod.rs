//! Machine kinematics (mill5, belt6) and timed joint trajectories: not implemented yet.
