"""camera_tracker end to end over DDS: published images in, PoseStamped / TwistStamped / Path / diagnostics out."""

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped
from nav_msgs.msg import Path
from sensor_msgs.msg import Image
from srs_testing import ros_args

from srs_ros.core.camera_calibration import save_calibration
from srs_ros.nodes.camera_tracker import array_to_image_msg, image_msg_to_array, seconds_to_stamp, stamp_to_seconds
from srs_ros.tools.synthetic_scene import (
    RobotAppearance,
    SyntheticCamera,
    SyntheticScene,
    constant_velocity_poses,
    write_video,
)

# A small camera (320 x 240, 0.6 m up) keeps the DDS messages light; ~2 mm per pixel, like the 640 x 480 default.
SCENE = SyntheticScene(camera=SyntheticCamera(width_px=320, height_px=240, height_m=0.6),
                       robot=RobotAppearance(marker_spacing_m=0.25))
VELOCITY_M_S = np.array([0.05, 0.02])


def yaw_of(msg):
    q = msg.pose.orientation
    return 2.0 * math.atan2(q.z, q.w)


def stamped(received, seconds):
    return [m for m in received if abs(stamp_to_seconds(m.header.stamp) - seconds) < 1e-6]


def statuses(diagnostics):
    return [s for array in diagnostics for s in array.status if s.name.endswith("marker tracking")]


def test_image_conversion_round_trip_with_padding_and_rgb():
    rng = np.random.default_rng(0)
    bgr = rng.integers(0, 255, (5, 7, 3), dtype=np.uint8)
    msg = array_to_image_msg(bgr, seconds_to_stamp(12.5))
    assert msg.encoding == "bgr8" and stamp_to_seconds(msg.header.stamp) == 12.5
    np.testing.assert_array_equal(image_msg_to_array(msg), bgr)
    padded = Image(height=5, width=7, encoding="rgb8", step=24)
    padded.data = np.pad(bgr[:, :, ::-1].reshape(5, 21), ((0, 0), (0, 3))).tobytes()
    np.testing.assert_array_equal(image_msg_to_array(padded), bgr)


@pytest.mark.timeout(120)
def test_tracker_node_over_dds(tmp_path, launch_node, ros_client):
    calibration = save_calibration(SCENE.camera.calibration(), tmp_path / "cal.yaml")
    node = launch_node("camera_tracker", ros_args({"calibration_file": str(calibration), "lost_timeout_s": 30.0,
                                                   "diagnostics_period_s": 0.2}))
    poses = ros_client.subscribe(PoseStamped, "/robot_pose")
    twists = ros_client.subscribe(TwistStamped, "/robot_twist")
    paths = ros_client.subscribe(Path, "/robot_path")
    diagnostics = ros_client.subscribe(DiagnosticArray, "/diagnostics")
    publisher = ros_client.node.create_publisher(Image, "/image_raw", 10)
    rng = np.random.default_rng(4)

    def send_until(frame, seconds, predicate, what):
        msg = array_to_image_msg(frame, seconds_to_stamp(seconds))
        last_sent = [-math.inf]

        def answered():
            # The node takes images best effort (sensor-data QoS): re-send every 0.5 s until it answers.
            if predicate():
                return True
            if time.monotonic() - last_sent[0] > 0.5:
                publisher.publish(msg)
                last_sent[0] = time.monotonic()
            return False

        try:
            ros_client.spin_until(answered, timeout_s=10.0, what=what)
        except AssertionError:
            raise AssertionError(f"timed out waiting for {what}; node log:\n{node.output()}") from None

    # 1. A moving robot: one pose per frame, stamped with the frame's stamp, within 2 mm and 1 degree.
    start = np.array([-0.08, -0.03, 0.6])
    for k in range(6):
        t = 100.0 + 0.1 * k
        truth = start + np.append(VELOCITY_M_S * 0.1 * k, 0.0)
        send_until(SCENE.render(truth, rng), t, lambda t=t: stamped(poses, t), f"pose of frame {k}")
        pose = stamped(poses, t)[0]
        assert pose.header.frame_id == "floor"
        assert math.hypot(pose.pose.position.x - truth[0], pose.pose.position.y - truth[1]) < 0.002
        assert abs(yaw_of(pose) - truth[2]) < math.radians(1.0)
    ros_client.spin_until(lambda: stamped(twists, 100.5), what="twist of the last frame")
    twist = stamped(twists, 100.5)[0].twist
    np.testing.assert_allclose([twist.linear.x, twist.linear.y], VELOCITY_M_S, atol=0.005)
    ros_client.spin_until(lambda: paths and len(paths[-1].poses) == 6, what="a 6-pose trail")
    ros_client.spin_until(lambda: statuses(diagnostics) and statuses(diagnostics)[-1].level == DiagnosticStatus.OK,
                          what="diagnostics OK while tracking")

    # 2. Head marker covered: no pose for that frame, WARN on /diagnostics naming the head.
    truth = start + np.append(VELOCITY_M_S * 0.6, 0.0)
    head = SCENE.robot.marker_centres_m(truth)["head"]
    cover = head + 0.035 * np.array([[-1, 0], [0.2, -1], [1, 0], [0.2, 1]])
    hidden = SCENE.render(truth, rng, occluders_m=[cover])

    def warned():
        found = statuses(diagnostics)
        return found and found[-1].level == DiagnosticStatus.WARN and "head" in found[-1].message

    send_until(hidden, 100.6, warned, "a WARN about the lost head marker")
    assert not stamped(poses, 100.6)

    # 3. Markers back: the pose returns and diagnostics go back to OK.
    send_until(SCENE.render(truth, rng), 100.7, lambda: stamped(poses, 100.7), "the pose after recovery")
    recovered = stamped(poses, 100.7)[0].pose.position
    assert math.hypot(recovered.x - truth[0], recovered.y - truth[1]) < 0.002
    ros_client.spin_until(lambda: statuses(diagnostics)[-1].level == DiagnosticStatus.OK, what="diagnostics OK again")
    assert not stamped(poses, 100.6)
    assert node.alive()
    assert node.stop() == 0
    assert "Traceback" not in node.log_path.read_text()


def test_tracker_node_reads_a_video_file_source(tmp_path, launch_node, ros_client):
    times, truth = constant_velocity_poses(1.0, 10.0, (-0.05, 0.0, -0.4), VELOCITY_M_S)
    video = write_video(tmp_path / "run.avi", SCENE, truth, 10.0)
    calibration = save_calibration(SCENE.camera.calibration(), tmp_path / "cal.yaml")
    poses = ros_client.subscribe(PoseStamped, "/robot_pose")
    node = launch_node("camera_tracker", ros_args({"calibration_file": str(calibration), "source": str(video),
                                                   "source_rate_hz": 20.0, "loop": True}))
    # The video loops, so poses keep coming whenever discovery completes.
    ros_client.spin_until(lambda: len(poses) >= 8, what="poses from the video")
    # Poses follow the video: stamps 0.1 s apart within a pass (the file's frame times), positions on the truth line.
    steps = np.diff([stamp_to_seconds(p.header.stamp) for p in poses])
    assert np.all(steps > 0) and np.sum(np.abs(steps - 0.1) < 1e-3) >= 5
    xy = np.array([[p.pose.position.x, p.pose.position.y] for p in poses])
    distance = np.min(np.linalg.norm(xy[:, None, :] - truth[None, :, :2], axis=2), axis=1)
    assert np.all(distance < 0.002)
    assert node.alive()
