"""In view, out of view, camera silent: what the frames say about the robot, for camera_tracker's /diagnostics."""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.vision.camera_calibration import DEFAULT_FRAME_ID

if TYPE_CHECKING:  # a type only: srs_bringup reads views without loading OpenCV
    from srs_ros.core.vision.tracking import TrackResult


class ViewState(enum.Enum):
    """What the frames say about the robot, with the diagnostic level each state is reported at."""

    TRACKING = "tracking"
    MARKERS_LOST = "markers_lost"    # frames without a pose for less than ``lost_after_s`` (a hand, a glare)
    OUT_OF_VIEW = "out_of_view"      # frames without a pose for ``lost_after_s`` or longer
    NO_IMAGES = "no_images"          # no frame yet, for less than ``image_timeout_s`` since the start
    CAMERA_SILENT = "camera_silent"  # no frame for ``image_timeout_s``: the camera or its driver stopped
    IMAGES_REFUSED = "images_refused"  # frames arrive but cannot be tracked (wrong size, encoding, empty)

    @property
    def level(self) -> str:
        """``"OK"``, ``"WARN"`` or ``"ERROR"``: a silent camera and refused images are faults, an unseen robot not."""
        return {"tracking": "OK", "camera_silent": "ERROR", "images_refused": "ERROR"}.get(self.value, "WARN")


@dataclass(frozen=True)
class ViewStatus:
    """The tracker's report at one moment: the state, a message for people, where the robot was last seen.

    ``last_seen_xy_m`` is the last published position (``frame_id``, normally the floor), ``last_seen_ago_s``
    how long before the report it was seen, ``last_image_ago_s`` the age of the newest frame (None: never).
    :meth:`values` and :meth:`from_values` carry it through ``/diagnostics`` key/values as text.
    """

    state: ViewState
    message: str = ""
    last_seen_xy_m: tuple[float, float] | None = None
    last_seen_ago_s: float | None = None
    last_image_ago_s: float | None = None
    frame_id: str = DEFAULT_FRAME_ID

    @property
    def level(self) -> str:
        """The diagnostic level of the state (``"OK"``, ``"WARN"``, ``"ERROR"``)."""
        return self.state.level

    @property
    def pose_current(self) -> bool:
        """True while poses still flow (tracking, or a short loss of markers); False out of view or camera silent."""
        return self.state in (ViewState.TRACKING, ViewState.MARKERS_LOST)

    def last_seen_text(self) -> str:
        """E.g. ``last seen 2.3 s ago at x 1.234 y -0.456 m (floor)``, or ``never seen``."""
        if self.last_seen_xy_m is None or self.last_seen_ago_s is None:
            return "never seen"
        x_m, y_m = self.last_seen_xy_m
        return f"last seen {self.last_seen_ago_s:.1f} s ago at x {x_m:.3f} y {y_m:.3f} m ({self.frame_id})"

    def summary(self) -> str:
        """One phrase for a status line when the robot's pose is not current ('' while it is)."""
        if self.state is ViewState.OUT_OF_VIEW:
            return f"robot out of the camera's view: {self.last_seen_text()}"
        if self.state is ViewState.CAMERA_SILENT:
            silent = "" if self.last_image_ago_s is None else f" for {self.last_image_ago_s:.1f} s"
            return f"camera silent: no images{silent}; robot {self.last_seen_text()}"
        if self.state is ViewState.NO_IMAGES:
            return "no camera images yet"
        if self.state is ViewState.IMAGES_REFUSED:
            return f"{self.message}; robot {self.last_seen_text()}"
        return ""

    def aged(self, seconds: float) -> ViewStatus:
        """The same report ``seconds`` later (the ages grow; the state is what was reported)."""
        return dataclasses.replace(self, last_seen_ago_s=_later(self.last_seen_ago_s, seconds),
                                   last_image_ago_s=_later(self.last_image_ago_s, seconds))

    def values(self) -> dict[str, str]:
        """Key/values for ``/diagnostics`` (positions in m, ages in s; absent when unknown)."""
        values = {"view_state": self.state.value, "last_seen_frame_id": self.frame_id}
        if self.last_seen_xy_m is not None:
            values["last_seen_x_m"], values["last_seen_y_m"] = (f"{v:.4f}" for v in self.last_seen_xy_m)
        if self.last_seen_ago_s is not None:
            values["last_seen_ago_s"] = f"{self.last_seen_ago_s:.3f}"
        if self.last_image_ago_s is not None:
            values["last_image_ago_s"] = f"{self.last_image_ago_s:.3f}"
        return values

    @classmethod
    def from_values(cls, values: Mapping[str, str], message: str = "") -> ViewStatus | None:
        """The report back from :meth:`values` (extra keys ignored); None without a known ``view_state``."""
        try:
            state = ViewState(values.get("view_state", ""))
            x_m, y_m = _number(values, "last_seen_x_m"), _number(values, "last_seen_y_m")
            return cls(state, message, None if x_m is None or y_m is None else (x_m, y_m),
                       _number(values, "last_seen_ago_s"), _number(values, "last_image_ago_s"),
                       values.get("last_seen_frame_id", DEFAULT_FRAME_ID))
        except ValueError:  # not one of ours, or a number that is not one
            return None


def _later(age_s: float | None, seconds: float) -> float | None:
    return None if age_s is None else age_s + seconds


def _number(values: Mapping[str, str], key: str) -> float | None:
    return float(values[key]) if key in values else None


class ViewWatch:
    """Whether the robot is in the camera's view, from each frame's :class:`TrackResult` and when frames arrive.

    Frames arriving without a pose for ``lost_after_s`` or longer: the robot is out of the camera's view
    (WARN, with where and how long ago it was last seen); for a shorter time its markers are only lost
    (WARN naming them). No frame for longer than ``image_timeout_s``: the camera is silent (ERROR), whatever
    was seen before. Frames that arrive but cannot be tracked (:meth:`refused`: a wrong size or encoding) are
    not silence: while the newest frame was refused the images are refused (ERROR, with the reason). Times are
    the caller's clock in seconds (``camera_tracker``: the steady clock at arrival, so a video's or a
    simulation's stamps do not matter). ``source`` names the images in messages.
    """

    def __init__(self, lost_after_s: float = 0.5, image_timeout_s: float = 1.0, start_s: float = 0.0,
                 frame_id: str = DEFAULT_FRAME_ID, source: str = "image_raw"):
        """Start watching at ``start_s`` (no frame yet)."""
        if not (lost_after_s > 0 and image_timeout_s > 0):
            raise ConfigurationError(f"lost_after_s {lost_after_s} s and image_timeout_s {image_timeout_s} s; "
                                     "both must be > 0 s.")
        self.lost_after_s, self.image_timeout_s = float(lost_after_s), float(image_timeout_s)
        self.frame_id, self.source = frame_id, source
        self._start_s = float(start_s)
        self._last_frame_s: float | None = None
        self._last_seen: tuple[float, float, float] | None = None  # (time s, x m, y m)
        self._unseen_since_s: float | None = None  # first frame without a pose since the last pose
        self._missing = ""
        self._refused = ""  # why the newest frame was refused ('' when it was tracked)

    def frame(self, now_s: float, result: TrackResult) -> None:
        """One frame arrived at ``now_s`` and gave ``result``."""
        self._last_frame_s = now_s
        self._refused = ""
        if result.tracked:
            self._last_seen = (now_s, float(result.pose[0]), float(result.pose[1]))
            self._unseen_since_s = None
            return
        self._missing = result.message
        if self._unseen_since_s is None:
            self._unseen_since_s = now_s

    def refused(self, now_s: float, reason: str) -> None:
        """A frame arrived at ``now_s`` but could not be tracked, for ``reason`` (no pose from it)."""
        self._last_frame_s = now_s
        self._refused = reason.rstrip(". ") or "unknown reason"
        if self._unseen_since_s is None:
            self._unseen_since_s = now_s

    def status(self, now_s: float) -> ViewStatus:
        """The report at ``now_s``."""
        seen = self._last_seen
        base = ViewStatus(ViewState.TRACKING, "tracking", None if seen is None else seen[1:],
                          None if seen is None else now_s - seen[0],
                          None if self._last_frame_s is None else now_s - self._last_frame_s, self.frame_id)
        say = partial(dataclasses.replace, base)
        if self._last_frame_s is None:
            waited_s = now_s - self._start_s
            if waited_s <= self.image_timeout_s:
                return say(state=ViewState.NO_IMAGES, message=f"no images received yet from {self.source}")
            return say(state=ViewState.CAMERA_SILENT,
                       message=f"no images from {self.source} for {waited_s:.1f} s since the start (camera silent)")
        silent_s = now_s - self._last_frame_s
        if silent_s > self.image_timeout_s:
            return say(state=ViewState.CAMERA_SILENT, message=f"no images from {self.source} for {silent_s:.1f} s "
                                                              f"(camera silent); robot {base.last_seen_text()}")
        if self._refused:
            return say(state=ViewState.IMAGES_REFUSED, message=f"images refused: {self._refused}; no pose published")
        if self._unseen_since_s is None:
            return base
        unseen_s = now_s - self._unseen_since_s
        if unseen_s < self.lost_after_s:
            return say(state=ViewState.MARKERS_LOST, message=f"markers lost ({self._missing}); no pose published")
        where = f"never seen in {unseen_s:.1f} s of images" if seen is None else base.last_seen_text()
        return say(state=ViewState.OUT_OF_VIEW,
                   message=f"robot out of the camera's view: {where}; no pose published ({self._missing})")
