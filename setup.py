"""ament_python build of srs_ros; also installable with pip (extras ``wheels``, ``test`` and ``cluster``)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "srs_ros"

# ROS 2 Jazzy from PyPI wheels, for machines without a ROS install. A stock ROS install provides
# these from the distro: do not install this extra there.
ROS_WHEELS = [
    "ros-jazzy-rclpy[fastrtps]==7.1.6",
    "ros-jazzy-common-interfaces==5.3.6",
    "ros-jazzy-std-srvs==5.3.6",
    "ros-jazzy-lifecycle-msgs==2.0.3",
]
# Hardware and vision libraries that a stock install takes from pip as well (see package.xml).
HARDWARE = ["python-can>=4.3", "cantools>=39", "nidaqmx>=1.0"]
VISION = ["opencv-contrib-python-headless>=4.8"]
# Dask distributed: `srs_sweep --scheduler tcp://HOST:8786` runs sweeps and calibrations on a cluster
# (docs/cluster.md); tested with 2026.8.0. Optional for users; the tests run a real LocalCluster, so `test` has it.
CLUSTER = ["dask>=2024.1", "distributed>=2024.1"]
TEST = CLUSTER + [
    "pytest>=8",
    "pytest-timeout>=2.3",
    "pytest-xdist>=3.5",
    "hypothesis>=6.100",
    "ruff>=0.6",
    "colcon-common-extensions>=0.3",
    "ros-jazzy-ament-package==0.16.4",
]

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", sorted(glob("config/*.yaml") + glob("config/*.dbc") + glob("config/*.xml"))),
        (f"share/{PACKAGE}/config/rigs", sorted(glob("config/rigs/*.yaml"))),
        (f"share/{PACKAGE}/launch", sorted(glob("launch/*.launch.py"))),
    ],
    python_requires=">=3.10",
    # MuJoCo runs the simulated robot (srs_ros/sim); tested with 4.0 (MjSpec model building, split wheels).
    # rosbags writes the sweep's rosbag2 recordings (MCAP) without a ROS install; tqdm draws its progress bar.
    install_requires=["setuptools", "numpy>=1.24", "scipy>=1.10", "PyYAML>=6", "matplotlib>=3.6", "mujoco>=4.0",
                      "rosbags>=0.11", "tqdm>=4.60"],
    extras_require={
        "wheels": ROS_WHEELS + HARDWARE + VISION,
        "hardware": HARDWARE,
        "vision": VISION,
        "cluster": CLUSTER,
        "test": TEST,
    },
    zip_safe=True,
    maintainer="srs_ros developers",
    maintainer_email="srs-ros@example.org",
    description="ROS 2 driver, kinematics and gait library for a pneumatic soft robotic snake.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "srs_trajectory = srs_ros.tools.trajectory_cli:main",
            "srs_kinematics = srs_ros.tools.kinematics_cli:main",
            "trajectory_server = srs_ros.nodes.trajectory_server:main",
            "gait_player = srs_ros.nodes.gait_player:main",
            "hardware_node = srs_ros.nodes.hardware_node:main",
            "srs_bringup = srs_ros.nodes.bringup:main",
            "camera_tracker = srs_ros.nodes.camera_tracker:main",
            "navigator = srs_ros.nodes.navigator:main",
            "srs_track = srs_ros.tools.track_cli:main",
            "srs_calibrate_camera = srs_ros.tools.calibrate_camera:main",
            "srs_wiring_check = srs_ros.tools.wiring_check:main",
            "srs_identify = srs_ros.tools.identify:main",
            "sim_world = srs_ros.nodes.sim_world:main",
            "srs_sim = srs_ros.tools.sim_cli:main",
            "srs_sweep = srs_ros.tools.sweep_cli:main",
            "srs_navigate = srs_ros.tools.navigate_cli:main",
            "srs_turning = srs_ros.tools.turning_cli:main",
        ],
    },
)
