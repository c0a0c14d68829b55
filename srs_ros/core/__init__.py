"""Pure-Python core of srs_ros: robot description, kinematics, gaits, fitting, actuation.

Nothing under ``srs_ros.core`` imports ROS; nodes wire these functions to topics and services.
"""
