"""The tracking code under OpenCV 4.6, the version of Ubuntu 24.04's python3-opencv (rosdep's key on Jazzy).

A second small virtual environment (``.venv-opencv46``, created on the first run and reused while its
requirements are unchanged; ``SRS_CV46_VENV`` moves it) holds the 4.6.0.66 wheel with numpy < 2 (4.6 is
built against numpy 1) and runs the ArUco, tracking, calibration and ``srs_track`` tests there.
"""

import fcntl
import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VENV = Path(os.environ.get("SRS_CV46_VENV", ROOT / ".venv-opencv46"))
REQUIREMENTS = ["opencv-contrib-python-headless==4.6.0.66", "numpy<2", "PyYAML>=6", "matplotlib>=3.6",
                "pytest>=8", "pytest-timeout>=2.3"]
TESTS = ["test/core/vision/test_aruco.py", "test/core/vision/test_tracking.py", "test/tools/test_track_cli.py",
         "test/tools/test_calibrate_camera.py"]
SCRIPTS = {"srs_track": "srs_ros.tools.track_cli", "srs_calibrate_camera": "srs_ros.tools.calibrate_camera"}


def _python() -> Path:
    return VENV / "bin" / "python"


def _ensure_venv() -> None:
    """Create the venv once (under a lock, so parallel runs share it); the package itself comes from the repo."""
    VENV.parent.mkdir(parents=True, exist_ok=True)
    with open(VENV.parent / f"{VENV.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        stamp = VENV / "srs_requirements.txt"
        wanted = "\n".join(REQUIREMENTS) + f"\nrepo {ROOT}\n"
        if stamp.is_file() and stamp.read_text() == wanted and _python().exists():
            return
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
        subprocess.run([str(_python()), "-m", "pip", "install", "--quiet", *REQUIREMENTS], check=True, timeout=600)
        site = subprocess.run([str(_python()), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                              check=True, capture_output=True, text=True).stdout.strip()
        Path(site, "srs_ros_repo.pth").write_text(f"{ROOT}\n")
        for script, module in SCRIPTS.items():  # what pip's console_scripts would install
            path = VENV / "bin" / script
            path.write_text(f"#!{_python()}\nimport sys\nfrom {module} import main\nsys.exit(main())\n")
            path.chmod(0o755)
        stamp.write_text(wanted)


@pytest.fixture(scope="module")
def python46():
    _ensure_venv()
    return _python()


def test_the_second_venv_has_opencv_46_with_the_old_aruco_api(python46):
    done = subprocess.run([str(python46), "-c", "import cv2; from srs_ros.core.vision import aruco; "
                           "print(cv2.__version__, aruco.has_class_api())"], capture_output=True, text=True, cwd=ROOT)
    assert done.stdout.split() == ["4.6.0", "False"], done.stderr


@pytest.mark.slow(seconds=30)
def test_tracking_tests_and_srs_track_pass_under_opencv_46(python46):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{python46.parent}{os.pathsep}{env.get('PATH', '')}"
    done = subprocess.run([str(python46), "-m", "pytest", "-q", "-x", *TESTS],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)
    tail = done.stdout[-3000:] + done.stderr[-2000:]
    assert done.returncode == 0, tail
    assert " passed" in done.stdout and " skipped" not in done.stdout, tail
    assert sys.executable != str(python46)
