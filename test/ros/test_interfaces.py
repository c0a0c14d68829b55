"""The message helpers every node shares: stamps and durations, diagnostics, images (round trip: camera tracker)."""

import cv2
import numpy as np
import pytest
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import Image

from srs_ros.core.errors import InvalidInputError
from srs_ros.ros.interfaces import (
    array_to_image_msg,
    diagnostic_array,
    diagnostic_status,
    diagnostic_values,
    image_msg_to_array,
    joint_state,
    nanoseconds_to_duration,
    nanoseconds_to_stamp,
    seconds_to_stamp,
    stamp_to_nanoseconds,
    stamp_to_seconds,
)


def test_stamps_and_durations_convert_to_seconds_and_exact_nanoseconds():
    stamp = Time(sec=1_700_000_000, nanosec=250_000_001)
    assert stamp_to_nanoseconds(stamp) == 1_700_000_000_250_000_001
    assert stamp_to_seconds(stamp) == pytest.approx(1_700_000_000.25)
    assert nanoseconds_to_stamp(1_700_000_000_250_000_001) == stamp
    assert nanoseconds_to_duration(2_500_000_000) == Duration(sec=2, nanosec=500_000_000)
    assert stamp_to_seconds(Duration(sec=2, nanosec=500_000_000)) == 2.5
    assert stamp_to_nanoseconds(Time()) == 0  # unstamped


def test_seconds_become_the_nearest_nanosecond_and_carry_into_the_next_second():
    assert seconds_to_stamp(12.5) == Time(sec=12, nanosec=500_000_000)
    assert seconds_to_stamp(0.9999999999) == Time(sec=1, nanosec=0)
    assert seconds_to_stamp(-0.25) == Time(sec=-1, nanosec=750_000_000)  # Time's own convention below zero


def test_a_diagnostic_status_takes_the_level_by_name_and_every_value_as_text():
    status = diagnostic_status("hardware_node: actuators", "mock", "WARN", "setpoints stale",
                               {"setpoints_received": 3, "output": "setpoints stale"})
    assert status.level == DiagnosticStatus.WARN and status.hardware_id == "mock"
    assert diagnostic_values(status) == {"setpoints_received": "3", "output": "setpoints stale"}
    array = diagnostic_array([status], Time(sec=5))
    assert array.header.stamp.sec == 5 and array.status == [status]
    with pytest.raises(InvalidInputError, match="diagnostic level 'FINE'; expected one of"):
        diagnostic_status("x", "y", "FINE", "", {})


@pytest.mark.parametrize(("encoding", "to_bgr"), [("rgb8", cv2.COLOR_RGB2BGR), ("bgra8", cv2.COLOR_BGRA2BGR),
                                                  ("rgba8", cv2.COLOR_RGBA2BGR), ("bgr8", None), ("8UC3", None),
                                                  ("mono8", None), ("8UC1", None)])
def test_images_become_what_opencv_converts_them_to(encoding, to_bgr):
    """Every encoding comes out as OpenCV's own conversion to BGR (mono stays mono), row padding removed."""
    channels = {"rgb8": 3, "bgra8": 4, "rgba8": 4, "bgr8": 3, "8UC3": 3, "mono8": 1, "8UC1": 1}[encoding]
    pixels = np.random.default_rng(channels).integers(0, 256, (4, 6, channels), dtype=np.uint8)
    msg = Image(height=4, width=6, encoding=encoding, step=6 * channels + 5)
    msg.data = np.pad(pixels.reshape(4, -1), ((0, 0), (0, 5))).tobytes()
    expected = cv2.cvtColor(pixels, to_bgr) if to_bgr is not None else pixels.squeeze(-1) if channels == 1 else pixels
    image = image_msg_to_array(msg)
    np.testing.assert_array_equal(image, expected)
    assert image.flags.c_contiguous and image.flags.writeable and image.dtype == np.uint8  # a copy of the data
    assert not np.shares_memory(image, np.frombuffer(msg.data, np.uint8))


@pytest.mark.parametrize(("encoding", "to_bgr"), [("bayer_rggb8", cv2.COLOR_BayerBG2BGR),
                                                  ("bayer_bggr8", cv2.COLOR_BayerRG2BGR),
                                                  ("bayer_gbrg8", cv2.COLOR_BayerGR2BGR),
                                                  ("bayer_grbg8", cv2.COLOR_BayerGB2BGR)])
def test_a_bayer_mosaic_is_written_as_its_filters_pass_and_read_back_in_colour(encoding, to_bgr):
    """A BGR image written as a Bayer camera's raw mosaic keeps, per pixel, the colour its filter passes (the
    tile named by the encoding: bayer_rggb8 is R G over G B); read back it is OpenCV's demosaicing (cv_bridge's
    table of codes), and a patch of one colour comes back exactly."""
    bgr = np.random.default_rng(3).integers(0, 256, (5, 7, 3), dtype=np.uint8)  # odd sides: a tile cut short
    msg = array_to_image_msg(bgr, encoding=encoding)
    assert (msg.encoding, msg.step, len(msg.data)) == (encoding, 7, 35)  # one byte a pixel
    raw = np.frombuffer(msg.data, np.uint8).reshape(5, 7)
    colour = {"r": 2, "g": 1, "b": 0}
    for row in range(2):
        for column in range(2):
            letter = encoding[6 + 2 * row + column]  # bayer_RGgb: the tile's first row, then its second
            np.testing.assert_array_equal(raw[row::2, column::2], bgr[row::2, column::2, colour[letter]])
    padded = Image(height=5, width=7, encoding=encoding, step=10)
    padded.data = np.pad(raw, ((0, 0), (0, 3))).tobytes()
    np.testing.assert_array_equal(image_msg_to_array(padded), cv2.cvtColor(raw, to_bgr))
    flat = np.empty((16, 16, 3), np.uint8)
    flat[:] = (200, 40, 10)
    np.testing.assert_array_equal(image_msg_to_array(array_to_image_msg(flat, encoding=encoding)), flat)


def test_an_encoding_that_cannot_be_written_is_refused_with_the_ones_that_can():
    with pytest.raises(InvalidInputError, match=r"cannot be written as 'yuv422'; expected one of \['bgr8', "
                                                r"'bayer_rggb8'.* for a BGR \(h, w, 3\) image"):
        array_to_image_msg(np.zeros((2, 2, 3), np.uint8), encoding="yuv422")
    with pytest.raises(InvalidInputError, match=r"cannot be written as 'bayer_rggb8'; expected one of \['mono8'\]"):
        array_to_image_msg(np.zeros((4, 4), np.uint8), encoding="bayer_rggb8")  # a mono image has no colours
    assert array_to_image_msg(np.zeros((4, 4), np.uint8)).encoding == "mono8"
    assert array_to_image_msg(np.zeros((4, 4), np.uint8), encoding="mono8").step == 4


def test_a_bayer_frame_too_small_to_demosaic_is_refused():
    """OpenCV demosaics a Bayer frame under 3x3 pixels as black: refused with the size expected."""
    msg = Image(height=2, width=2, encoding="bayer_rggb8", step=2, data=bytes([200, 100, 100, 50]))
    with pytest.raises(InvalidInputError, match=r"2x2 bayer_rggb8 is too small to demosaic; expected at least 3x3"):
        image_msg_to_array(msg)


def test_a_joint_state_leaves_what_was_not_measured_empty():
    full = joint_state(["a", "b"], seconds_to_stamp(2.5), np.array([0.01, 0.02]), [1.0, 2.0])
    assert full.name == ["a", "b"] and stamp_to_seconds(full.header.stamp) == 2.5
    assert list(full.position) == [0.01, 0.02] and list(full.effort) == [1.0, 2.0]
    lengths_only = joint_state(["a", "b"], seconds_to_stamp(0.0), [0.01, 0.02])
    assert list(lengths_only.position) == [0.01, 0.02] and list(lengths_only.effort) == []
