"""Hostile images against camera_tracker as a process: it must refuse them with a reason and keep tracking.

Hypothesis draws sensor_msgs/Image messages as a broken driver or a hostile sender would make them:
empty, 1x1, unsupported or empty encodings, steps and sizes that disagree with the data, endianness
flags, random bytes, stamps out of range or going backwards, and good frames with hostile stamps.
After each one a good frame must still give its pose: the node is alive and tracking, and nothing
it publishes is non-finite.
"""

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, TwistStamped
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import Image
from srs_testing import ros_args

from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.ros.interfaces import array_to_image_msg, seconds_to_stamp, stamp_to_seconds
from srs_ros.sim.scene import RobotAppearance, SyntheticCamera, SyntheticScene

SCENE = SyntheticScene(camera=SyntheticCamera(width_px=320, height_px=240, height_m=0.6),
                       robot=RobotAppearance(marker_spacing_m=0.25))
ENCODINGS = ["bgr8", "rgb8", "mono8", "8UC1", "8UC3", "bgra8", "rgba8", "bayer_rggb8", "bayer_gbrg8"]
CHANNELS = {"bgr8": 3, "rgb8": 3, "mono8": 1, "8UC1": 1, "8UC3": 3, "bgra8": 4, "rgba8": 4, "bayer_rggb8": 1,
            "bayer_gbrg8": 1}
SETTINGS = settings(max_examples=25, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck), report_multiple_bugs=False)


@st.composite
def hostile_images(draw, good_frame: np.ndarray):
    kind = draw(st.sampled_from(["raw", "raw", "raw", "good_frame_bad_stamp", "good_frame_bad_layout"]))
    if kind.startswith("good_frame"):
        msg = array_to_image_msg(good_frame)
        if kind == "good_frame_bad_layout":
            msg.encoding = draw(st.sampled_from(["rgba8", "mono8", "16UC1", "", "bayer_grbg8"]))
            msg.step = draw(st.sampled_from([0, msg.step - 1, msg.step * 2, 2**32 - 1]))
    else:
        encoding = draw(st.one_of(st.sampled_from(ENCODINGS + ["16UC1", "bayer_rggb16", "", "BGR8"]),
                                  st.text(max_size=8)))
        height = draw(st.one_of(st.sampled_from([0, 1, 2, 2**31, 2**32 - 1]), st.integers(0, 200)))
        width = draw(st.one_of(st.sampled_from([0, 1, 2, 2**31, 2**32 - 1]), st.integers(0, 200)))
        row = width * CHANNELS.get(encoding, 1)
        step = draw(st.one_of(st.just(row), st.sampled_from([0, max(row - 1, 0), row + 3, 2**32 - 1])))
        step = min(step, 2**32 - 1)
        size = step * height if step * height <= 200_000 else draw(st.integers(0, 4096))
        size = draw(st.one_of(st.just(size), st.integers(0, 4096)))
        seed = draw(st.integers(0, 2**32 - 1))
        msg = Image(height=height, width=width, encoding=encoding, step=step,
                    is_bigendian=draw(st.sampled_from([0, 1, 255])))
        msg.data = np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8).tobytes()
    msg.header.frame_id = draw(st.text(max_size=20))
    sec, nanosec = draw(st.sampled_from([(-2**31, 0), (2**31 - 1, 2**32 - 1), (0, 0), (5, 2**32 - 1), (50, 0)]))
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    return msg


@pytest.mark.slow(seconds=5)
def test_hostile_images_are_refused_and_tracking_goes_on(tmp_path, launch_node, ros_client):
    calibration = save_calibration(SCENE.camera.calibration(), tmp_path / "cal.yaml")
    node = launch_node("camera_tracker", ros_args({"calibration_file": str(calibration), "image_timeout_s": 30.0}))
    client = ros_client
    poses = client.subscribe(PoseStamped, "/robot_pose")
    twists = client.subscribe(TwistStamped, "/robot_twist")
    publisher = client.node.create_publisher(Image, "/image_raw", 10)
    rng = np.random.default_rng(7)
    frame = SCENE.render(np.array([-0.08, -0.03, 0.6]), rng)
    clock_s = [1000.0]

    def tracked_again() -> None:
        """A good frame with the next stamp gives its pose (re-sent: images are best effort)."""
        clock_s[0] += 0.1
        msg = array_to_image_msg(frame, seconds_to_stamp(clock_s[0]))
        stamp = clock_s[0]

        def answered() -> bool:
            if any(abs(stamp_to_seconds(p.header.stamp) - stamp) < 1e-6 for p in poses):
                return True
            publisher.publish(msg)
            client.spin_for(0.05)
            return False

        assert node.alive(), node.output()[-3000:]
        client.spin_until(answered, 10.0, f"the pose of a good frame (node alive: {node.alive()})")

    tracked_again()

    @SETTINGS
    @given(hostile_images(frame))
    @example(Image(height=0, width=0, encoding="bgr8"))  # an empty frame once stopped the tracker (cv2.error)
    @example(Image(height=0, width=320, encoding="mono8", step=320))
    @example(Image(height=240, width=320, encoding="bgr8", step=960, data=bytes(10)))  # data short of the size
    def one_hostile_image(msg):
        for _ in range(2):
            publisher.publish(msg)
            client.spin_for(0.02)
        tracked_again()

    one_hostile_image()
    assert node.alive() and "Traceback" not in node.output()
    values = [v for p in poses for v in (p.pose.position.x, p.pose.position.y, p.pose.orientation.z)]
    values += [v for t in twists for v in (t.twist.linear.x, t.twist.linear.y, t.twist.angular.z)]
    assert all(math.isfinite(v) for v in values)
    assert "image" in node.output()  # the refusals are said (throttled to one line per 5 s)
