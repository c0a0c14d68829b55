"""The robot seen by an overhead camera, without ROS: markers, the floor calibration, the pose and its velocity.

``aruco`` (either OpenCV ArUco API), ``homography`` (fitting a plane homography), ``camera_calibration``
(image pixels -> floor metres: homography, lens), ``detectors`` (ArUco with ROI search, colour blobs),
``tracking`` (pose, velocity, Table I's traveling velocity), ``view`` (in view, out of view, camera silent,
images refused: for /diagnostics).
"""

from srs_ros.core import lazy_exports

_EXPORTS = {
    "CameraCalibration": "camera_calibration", "load_calibration": "camera_calibration",
    "ArucoMarkerDetector": "detectors", "ColorBlobDetector": "detectors",
    "Tracker": "tracking", "TrackerConfig": "tracking", "TrackResult": "tracking",
    "traveling_velocity": "tracking", "pose_from_markers": "tracking",
    "ViewWatch": "view", "ViewStatus": "view", "ViewState": "view",
}
__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
