"""What every ROS-facing part of srs_ros shares (nodes, the sim backend, experiments, tests, benchmarks).

``interfaces`` (every topic name, QoS profile and message helper: the ROS contract in one place),
``parameters`` (parameter specs, declared once per node, integers taken as doubles, guarded services),
``process`` (init, steady-clock timers, spinning, signals, real-time priority, start-up errors),
``gait_driver`` (the navigator's gait commands through the gait nodes' parameters and services),
``navigation_markers`` (what the navigator draws for RViz).
"""
