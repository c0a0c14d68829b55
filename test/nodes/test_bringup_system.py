"""srs_bringup's nodes and executors in the test's own process: what is made is destroyed, whatever fails."""

import rclpy

from srs_ros.core.errors import ConfigurationError
from srs_ros.nodes import bringup
from srs_ros.nodes.sim_world import SimWorldNode
from srs_ros.ros.process import CleanExit


def test_a_world_made_before_a_start_up_failure_is_stopped_and_destroyed_before_rclpy_shuts_down(ros_domain,
                                                                                                  monkeypatch):
    def refused():
        raise ConfigurationError("amplitude_bar out of range (injected)")

    monkeypatch.setattr(bringup, "TrajectoryServer", refused)
    rclpy.init(args=["srs_bringup", "--ros-args", "-p", "camera_rate_hz:=0.0"], domain_id=ros_domain)
    system, outcome = bringup.System(), CleanExit()
    try:
        with outcome:
            system.create_nodes(bringup.build_parser().parse_args([]))  # the sim rig: its world comes first
    finally:
        world = system.world_nodes[0] if system.world_nodes else None
        system.stop(outcome)
    assert outcome.exit_code == 2 and system.hardware is None
    assert isinstance(world, SimWorldNode)
    assert not world._thread.is_alive()  # its physics thread stepped and published on while rclpy shut down
    assert not rclpy.ok()
