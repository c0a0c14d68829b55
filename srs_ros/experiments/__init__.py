"""Experiments like the paper's Sec. IV: sweeps of gait x amplitude x frequency reduced to Table I.

Pure Python, no ROS: :mod:`~srs_ros.experiments.table` (measured tables such as the paper's Table I, run
records, CSV and the paper's layout), :mod:`~srs_ros.experiments.sweep` (the grid and the parallel offline
runner on the simulated robot), :mod:`~srs_ros.experiments.cluster` (the same runner on a Dask cluster),
:mod:`~srs_ros.experiments.calibration` (fitting the simulation's uncertain parameters to a measured
table), :mod:`~srs_ros.experiments.plots` (figures) and :mod:`~srs_ros.experiments.recording` (rosbag2
directories with ``rosbags``). The one module that imports rclpy is
:mod:`~srs_ros.experiments.ros_sweep`, the same sweep as a client of running nodes.
"""
