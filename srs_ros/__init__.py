"""srs_ros: ROS 2 driver, kinematics and gait library for a pneumatic soft robotic snake."""

__version__ = "0.1.0"
