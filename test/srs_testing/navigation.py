"""The navigator on the simulated robot, every node a process of its own over DDS (tests and benchmarks).

:class:`NavigationSystem` starts sim_world (MuJoCo, its overhead camera), camera_tracker (colour bands),
hardware_node (sim rig), trajectory_server, gait_player (no autostart) and the navigator on a
:class:`~srs_testing.ros.RosSession`'s domain, and gives the client's view of them: the navigator's progress and
RViz markers, the commanded pressures, the tracked pose and the simulator's ground truth (read by the harness only, to
check where the robot really is; the navigator never sees it). The processes use the launch file's Fast DDS profile, so
camera images travel through shared memory. Random goals as the issue's statistical test
asks them: :func:`srs_ros.sim.navigation.random_goals`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

#: The navigator's states in which it has stopped working on a goal.
FINAL_STATES = frozenset({"reached", "cancelled", "pose_lost", "failed"})


class NavigationSystem:
    """The module's process set and what the test client sees of it (see the module docstring)."""

    def __init__(self, session, navigator_params: Mapping[str, Any] | None = None, camera_rate_hz: float = 30.0,
                 sim_config_file: str = ""):
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import Path
        from std_msgs.msg import Float64MultiArray, String
        from std_srvs.srv import Trigger
        from visualization_msgs.msg import MarkerArray

        from srs_ros.core.robot import config_dir
        from srs_ros.ros.interfaces import (
            COMMANDED_PRESSURE_TOPIC,
            GOAL_PATH_TOPIC,
            GOAL_POSE_TOPIC,
            GROUND_TRUTH_TOPIC,
            NAVIGATION_MARKERS_TOPIC,
            NAVIGATION_PROGRESS_TOPIC,
            POSE_TOPIC,
            latched_qos,
        )
        from srs_testing.ros import ros_args

        self.session = session
        self.client = client = session.client
        rig = str(config_dir() / "rigs" / "sim.yaml")
        world = {"camera_rate_hz": camera_rate_hz, "markers_rate_hz": 0.0}
        self.world = session.launch("sim_world", ros_args({**world, **({"sim_config_file": sim_config_file}
                                                                        if sim_config_file else {})}))
        self.tracker = session.launch("camera_tracker", ros_args({"color_preset": "sim_bands"}))
        self.hardware = session.launch("hardware_node", ros_args({"autostart": True, "rig_file": rig}))
        session.launch("trajectory_server", ros_args({"samples": 32}))
        session.launch("gait_player", ros_args({"autostart": False}))
        self.navigator = session.launch("navigator", ros_args({"calibration_preset": "sim_bands",
                                                               **(navigator_params or {})}))
        self.progress = client.subscribe(String, NAVIGATION_PROGRESS_TOPIC, latched_qos())
        self.markers = client.subscribe(MarkerArray, NAVIGATION_MARKERS_TOPIC, latched_qos())
        self.pressures = client.subscribe(Float64MultiArray, COMMANDED_PRESSURE_TOPIC)
        self.tracked = client.subscribe(PoseStamped, POSE_TOPIC)
        self.truth = client.subscribe(PoseStamped, GROUND_TRUTH_TOPIC)
        self._goal_pub = client.node.create_publisher(PoseStamped, GOAL_POSE_TOPIC, 10)
        self._path_pub = client.node.create_publisher(Path, GOAL_PATH_TOPIC, 10)
        self._pose_type, self._path_type = PoseStamped, Path
        client.discover([(Trigger, "/navigator/cancel"), (Trigger, "/sim_world/reset")], timeout_s=60.0)
        self.wait(lambda: (self.tracked and self.progress and self.pressures and self._goal_pub.get_subscription_count()
                           and self._path_pub.get_subscription_count()), 90.0,
                  "tracked poses, the navigator's progress and the hardware's commands")

    # ------------------------------------------------------------- what is seen
    def state(self) -> dict[str, Any]:
        """The navigator's latest progress (its JSON fields)."""
        from srs_ros.ros.interfaces import progress_fields

        return progress_fields(self.progress[-1])

    def marker(self, namespace: str):
        """The navigator's newest RViz marker of ``namespace`` ("goal", "status", "path ahead", "track"), or None."""
        newest = {m.ns: m for m in self.markers[-1].markers} if self.markers else {}
        return newest.get(namespace)

    @staticmethod
    def xy(poses) -> np.ndarray:
        """The newest of a list of PoseStamped as (x, y) m."""
        return np.array([poses[-1].pose.position.x, poses[-1].pose.position.y])

    def vented(self) -> bool:
        """True when the hardware node's newest command is 0 bar on every muscle."""
        return bool(self.pressures) and max(self.pressures[-1].data) == 0.0

    def commanding(self, above_bar: float = 1.0) -> bool:
        """True when the newest command has a muscle above ``above_bar``."""
        return bool(self.pressures) and max(self.pressures[-1].data) > above_bar

    def logs(self, chars: int = 3000) -> str:
        """The end of every process's output (for a failure message)."""
        return "\n".join(f"--- {p.script}:\n{p.output()[-chars:]}" for p in self.session.started)

    def wait(self, predicate, timeout_s: float, what: str) -> None:
        """Spin until ``predicate()``; AssertionError with the last progress and the logs on timeout."""
        try:
            self.client.spin_until(predicate, timeout_s, what)
        except AssertionError as exc:
            last = self.state() if self.progress else "none"
            raise AssertionError(f"{exc}; last progress {last}\n{self.logs()}") from None

    def wait_state(self, states: Iterable[str], timeout_s: float, what: str) -> dict[str, Any]:
        """Spin until the navigator's state is one of ``states``; its progress then."""
        states = frozenset(states)
        self.wait(lambda: self.state()["state"] in states, timeout_s, what)
        return self.state()

    # ------------------------------------------------------------- what is sent
    def goal(self, x_m: float, y_m: float, frame_id: str = "floor") -> None:
        """Publish a goal on goal_pose, as RViz's "2D Goal Pose" does."""
        msg = self._pose_type()
        msg.header.frame_id = frame_id
        msg.pose.position.x, msg.pose.position.y = float(x_m), float(y_m)
        msg.pose.orientation.w = 1.0
        self._goal_pub.publish(msg)

    def path(self, points) -> None:
        """Publish waypoints on goal_path (frame floor)."""
        msg = self._path_type()
        msg.header.frame_id = "floor"
        for x_m, y_m in points:
            pose = self._pose_type()
            pose.pose.position.x, pose.pose.position.y = float(x_m), float(y_m)
            msg.poses.append(pose)
        self._path_pub.publish(msg)

    def set_navigator(self, **values: Any) -> None:
        """Set navigator parameters (like ``ros2 param set``); AssertionError if one is refused."""
        results = self.client.set_parameters("navigator", values)
        assert all(r.successful for r in results), [r.reason for r in results]

    def at_rest_at_start(self) -> np.ndarray:
        """Cancel whatever runs, wait for the vent, put the robot back at its start pose; its tracked (x, y)."""
        self.client.trigger("/navigator/cancel")
        self.wait(self.vented, 15.0, "the vent")
        self.client.trigger("/sim_world/reset")
        self.client.spin_for(0.3)
        count = len(self.tracked)
        self.wait(lambda: len(self.tracked) > count + 5, 20.0, "tracked poses after the reset")
        return self.xy(self.tracked)
