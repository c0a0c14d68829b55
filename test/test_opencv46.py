"""The tracking code under OpenCV 4.6, the version of Ubuntu 24.04's python3-opencv (rosdep's key on Jazzy).

The second small virtual environment (:mod:`srs_testing.opencv46`: ``.venv-opencv46``, made by scripts/test.sh
before the suite, or here on the first run) holds the 4.6.0.66 wheel with numpy < 2 and runs the ArUco,
tracking, calibration and ``srs_track`` tests there.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from srs_testing.opencv46 import ensure_venv

ROOT = Path(__file__).resolve().parents[1]
TESTS = ["test/core/vision/test_aruco.py", "test/core/vision/test_tracking.py", "test/tools/test_track_cli.py",
         "test/tools/test_calibrate_camera.py"]


@pytest.fixture(scope="module")
def python46():
    return ensure_venv()


def test_the_second_venv_has_opencv_46_with_the_old_aruco_api(python46):
    done = subprocess.run([str(python46), "-c", "import cv2; from srs_ros.core.vision import aruco; "
                           "print(cv2.__version__, aruco.has_class_api())"], capture_output=True, text=True, cwd=ROOT)
    assert done.stdout.split() == ["4.6.0", "False"], done.stderr


@pytest.mark.slow(seconds=65)  # in the whole suite (scripts/test.sh) on the 2-core machine, 2026-11-28
def test_tracking_tests_and_srs_track_pass_under_opencv_46(python46):
    # Its own run of its files, whichever phase of scripts/test.sh this is (a quiet test among them would be lost)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "SRS_TEST_PHASE")}
    env["PATH"] = f"{python46.parent}{os.pathsep}{env.get('PATH', '')}"
    done = subprocess.run([str(python46), "-m", "pytest", "-q", "-x", *TESTS],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)
    tail = done.stdout[-3000:] + done.stderr[-2000:]
    assert done.returncode == 0, tail
    assert " passed" in done.stdout and " skipped" not in done.stdout, tail
    assert sys.executable != str(python46)
