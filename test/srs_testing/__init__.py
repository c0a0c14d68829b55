"""The test harness of srs_ros, shared by the tests (test/) and the benchmarks (benchmarks/).

Modules:

- :mod:`srs_testing.ros`: nodes over real DDS. Private ``ROS_DOMAIN_ID`` per test (:func:`allocate_domain`,
  :func:`release_domain`), node processes started by their console scripts (:class:`NodeProcess`,
  :func:`ros_args`, :func:`script_path`), the rclpy client that does what ``ros2 topic echo`` / ``ros2
  service call`` / ``ros2 param set`` / ``ros2 lifecycle set`` do (:class:`RosClient`), all of it for longer
  than one test (:class:`RosSession`: a node process several tests share; a context manager that stops
  every process it started, pass or fail), the simulated loop as the launch file starts it
  (:func:`launch_sim_loop`), and Fast DDS's shared memory cleaned after a process was killed
  (:func:`fastdds_shm_clean_if_killed`).
- :mod:`srs_testing.backend`: what the mock backend of a node in another process wrote (:func:`recorded_rig`,
  :class:`BackendRecord`), and a clock for a mock backend in the test's own process (:class:`ManualClock`).
- :mod:`srs_testing.gaits`: gait cycles as a sender publishes them (:data:`JOINT_NAMES`, :func:`rolling_cycle`,
  :func:`trajectory`).
- :mod:`srs_testing.hardware_rig`: the hardware node as a separate process, shared by the tests of a module
  (the pytest fixtures ``hardware`` and ``shared_nodes``, :class:`~srs_testing.hardware_rig.Rig`); not imported
  here: ``from srs_testing.hardware_rig import ...``.
- :mod:`srs_testing.netns`: several hosts on one machine as network namespaces (:class:`NetnsLab`, root only).
- :mod:`srs_testing.navigation`: the navigator on the simulated robot, every node a process
  (:class:`~srs_testing.navigation.NavigationSystem`); not imported here: ``from srs_testing.navigation import
  NavigationSystem``.
- :mod:`srs_testing.cpu`: the CPU time of a benchmark's descendants, the local pool's forkserver workers included
  (:func:`~srs_testing.cpu.descendants_cpu_s`; not imported here).
- :mod:`srs_testing.opencv46`: the second virtual environment with OpenCV 4.6
  (:func:`~srs_testing.opencv46.ensure_venv`; scripts/test.sh makes it before pytest starts).
- :mod:`srs_testing.stream`: one measured run of the whole setpoint stream (soak, CPU-load and multi-host
  benchmarks and tests); it runs :mod:`srs_testing.stream_probe` as the observer process. Not imported here
  (it loads the synthetic camera): ``from srs_testing.stream import run_stream``.

The tests find this package through pytest's ``pythonpath = test`` (setup.cfg); the development install
(scripts/setup.sh) installs it editable from test/pyproject.toml, so benchmarks import it as any package.
It is never part of a colcon/ament install (see the README's "Tests" section).
"""

from srs_testing.backend import BackendRecord, ManualClock, recorded_rig
from srs_testing.gaits import JOINT_NAMES, rolling_cycle, trajectory
from srs_testing.netns import NetnsLab
from srs_testing.ros import (
    NodeProcess,
    RosClient,
    RosSession,
    allocate_domain,
    camera_profile_env,
    fastdds_shm_clean,
    fastdds_shm_clean_if_killed,
    launch_sim_loop,
    note_killed,
    release_domain,
    ros_args,
    script_path,
)

__all__ = [
    "JOINT_NAMES", "BackendRecord", "ManualClock", "NetnsLab", "NodeProcess", "RosClient", "RosSession",
    "allocate_domain",
    "camera_profile_env", "fastdds_shm_clean", "fastdds_shm_clean_if_killed", "launch_sim_loop", "note_killed",
    "recorded_rig",
    "release_domain", "rolling_cycle", "ros_args", "script_path", "trajectory",
]
