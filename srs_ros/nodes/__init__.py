"""ROS 2 nodes of srs_ros: thin wiring of the core to topics, services and parameters."""
