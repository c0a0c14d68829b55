"""The synthetic overhead scene and its camera's calibration, shared by the vision tests of this folder."""

import pytest

from srs_ros.sim.scene import SyntheticScene


@pytest.fixture(scope="module")
def scene():
    return SyntheticScene()


@pytest.fixture(scope="module")
def calibration(scene):
    return scene.camera.calibration()
