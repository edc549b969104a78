"""The bridge over DDS: a team's ROS 2 nodes on their default middleware (Fast DDS) drive a
simulated robot in lockstep, through a relay that runs under a ROS 2 Python of its own, so
kartci itself has no dependency on rclpy."""
