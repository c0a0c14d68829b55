"""The second, small virtual environment with OpenCV 4.6 (Ubuntu 24.04's python3-opencv, rosdep's key on Jazzy).

``.venv-opencv46`` (``SRS_CV46_VENV`` moves it) holds the 4.6.0.66 wheel with numpy < 2 (4.6 is built against
numpy 1) and the repo on its path; test/test_opencv46.py runs the tracking tests in it. :func:`ensure_venv`
creates it once, under a lock (parallel runs share it), and again only when its requirements change.
scripts/test.sh calls it (``python -m srs_testing.opencv46``) before pytest starts, on a quiet machine, so
that the first run of a fresh clone does not install packages beside the suite's busiest minute.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(os.environ.get("SRS_CV46_VENV", ROOT / ".venv-opencv46"))
REQUIREMENTS = ["opencv-contrib-python-headless==4.6.0.66", "numpy<2", "PyYAML>=6", "matplotlib>=3.6",
                "pytest>=8", "pytest-timeout>=2.3", "tqdm>=4.60"]
SCRIPTS = {"srs_track": "srs_ros.tools.track_cli", "srs_calibrate_camera": "srs_ros.tools.calibrate_camera"}


def venv_python() -> Path:
    """The OpenCV 4.6 environment's interpreter."""
    return VENV / "bin" / "python"


def ensure_venv() -> Path:
    """Create the environment if it is missing or its requirements changed; its interpreter."""
    VENV.parent.mkdir(parents=True, exist_ok=True)
    with open(VENV.parent / f"{VENV.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        stamp = VENV / "srs_requirements.txt"
        wanted = "\n".join(REQUIREMENTS) + f"\nrepo {ROOT}\n"
        if stamp.is_file() and stamp.read_text() == wanted and venv_python().exists():
            return venv_python()
        print(f"srs_ros: creating {VENV} (OpenCV 4.6 for the tracking tests, once)", file=sys.stderr)
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
        subprocess.run([str(venv_python()), "-m", "pip", "install", "--quiet", *REQUIREMENTS], check=True,
                       timeout=600)
        site = subprocess.run([str(venv_python()), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                              check=True, capture_output=True, text=True).stdout.strip()
        Path(site, "srs_ros_repo.pth").write_text(f"{ROOT}\n")
        for script, module in SCRIPTS.items():  # what pip's console_scripts would install
            path = VENV / "bin" / script
            path.write_text(f"#!{venv_python()}\nimport sys\nfrom {module} import main\nsys.exit(main())\n")
            path.chmod(0o755)
        stamp.write_text(wanted)
        return venv_python()


if __name__ == "__main__":
    ensure_venv()
