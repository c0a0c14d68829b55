"""The synthetic camera's ArUco markers: warped into their bounding box, they look as warped over the whole image."""

import math

import cv2
import numpy as np
import pytest

from srs_ros.sim.scene import RobotAppearance, SyntheticCamera, SyntheticScene
from srs_ros.sim.scene import aruco_dictionary as dictionary


class WholeImageWarp(SyntheticScene):
    """The reference: each marker and its mask warped over the whole supersampled image, blended where the mask is
    (the renderer until 2026-11-28: the OpenCV 4.6 run of the tracking tests took 2.5 times the CPU)."""

    def _draw_aruco(self, image, marker_id, centre_m, yaw_rad, size_m=None):
        texture = self._marker_texture(marker_id)
        cells = dictionary(self.robot.aruco_dictionary).markerSize + 2
        side_px = texture.shape[0]
        m = (size_m or self.robot.marker_size_m) / (cells * side_px / (cells + 2))
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        texture_to_local = np.array([[m, 0.0, -m * side_px / 2], [0.0, -m, m * side_px / 2], [0.0, 0.0, 1.0]])
        local_to_floor = np.array([[c, -s, centre_m[0]], [s, c, centre_m[1]], [0.0, 0.0, 1.0]])
        h, size = self._h_floor_to_big @ local_to_floor @ texture_to_local, self._big_size()
        warped = cv2.warpPerspective(cv2.cvtColor(texture, cv2.COLOR_GRAY2BGR), h, size, flags=cv2.INTER_LINEAR)
        mask = cv2.warpPerspective(np.full(texture.shape, 255, np.uint8), h, size, flags=cv2.INTER_LINEAR)
        alpha = mask[..., None].astype(np.float32) / 255.0
        image[...] = (alpha * warped + (1.0 - alpha) * image).astype(np.uint8)


@pytest.mark.parametrize("camera, robot, supersample, poses", [
    (SyntheticCamera(tilt_rad=math.radians(25.0)), RobotAppearance(), 3, [(-0.35, -0.1, 0.3)]),  # the tracking test's
    (SyntheticCamera(height_m=0.4), RobotAppearance(marker_size_m=0.2), 3,  # a texture pixel over 5.8 image pixels
     [(0.0, 0.0, 0.0), (0.05, 0.0, 1.0), (3.0, 0.0, 0.0)]),  # the last out of view
])
def test_markers_warped_into_their_box_match_the_whole_image_warp(camera, robot, supersample, poses):
    options = dict(camera=camera, robot=robot, supersample=supersample, noise_sigma=0.0, blur_sigma_px=0.0)
    boxed, whole = SyntheticScene(**options), WholeImageWarp(**options)  # each draws its floor once
    for pose in poses:
        difference = np.abs(boxed.render(pose).astype(int) - whole.render(pose).astype(int))
        assert difference.max() <= 1, pose  # the same but for rounding in the interpolation
