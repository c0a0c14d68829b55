"""Where a tool writes: output folders and files checked before the work.

So a long run (or real air) is not lost to a path that cannot be written at the end.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from srs_ros.core.errors import ConfigurationError


def prepare_output(path: str | Path, flag: str = "--out") -> Path:
    """The output folder, created and proven writable; :class:`ConfigurationError` otherwise."""
    out = Path(path)
    _writable_folder(out, flag, path)
    return out


def prepare_output_file(path: str | Path | None, flag: str) -> Path | None:
    """An output file's path (None passes through), its folder created and proven writable, before any work.

    :class:`ConfigurationError` names the option and the reason: a folder where a file is expected, or a folder
    that cannot be written (``/proc``, a read-only mount, no permission).
    """
    if path is None:
        return None
    out = Path(path)
    if out.is_dir():
        raise ConfigurationError(f"{flag} {path}: is a folder; expected a file path in it (e.g. {out / 'run.csv'}).")
    _writable_folder(out.parent, flag, path)
    return out


def check_distinct_paths(paths: dict[str, str | Path | None]) -> None:
    """Refuse two of ``paths`` ({option or role: path}, None left out) that are one file.

    An output written over an input (``srs_track run.avi --out run.avi`` replaced the video with the CSV) or over
    another output.
    """
    seen: dict[Path, str] = {}
    for flag, path in paths.items():
        if path is None:
            continue
        key = Path(path).resolve()
        if key in seen:
            raise ConfigurationError(f"{flag} {path}: the same file as {seen[key]}; expected a path of its own.")
        seen[key] = flag


def _writable_folder(folder: Path, flag: str, given: str | Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".srs_probe_"):
            pass
    except OSError as exc:
        raise ConfigurationError(f"{flag} {given}: cannot write there ({exc.strerror or exc}); choose a writable "
                                 "folder.") from None


def partial_path(path: str | Path) -> Path:
    """Where an output is written until the run succeeds: a hidden sibling, put in place by ``os.replace``."""
    path = Path(path)
    return path.with_name(f".{path.stem}.partial{path.suffix}")


class VideoFile:
    """An MJPG video written under a temporary name and put in place by :meth:`keep` once the run succeeded.

    A run that fails or is interrupted leaves no partial video, and a file already at ``path`` is not touched until
    then (a helper's review: a typo in a gait's arguments wiped an existing video; Ctrl-C left 9-11 MB partial ones).
    :meth:`close` releases the writer and removes a video not kept.
    """

    def __init__(self, path: str | Path, fps: float, size_px: tuple[int, int]):
        import cv2

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.partial = partial_path(self.path)
        self.writer = cv2.VideoWriter(str(self.partial), cv2.VideoWriter_fourcc(*"MJPG"), fps, tuple(size_px))
        if not self.writer.isOpened():
            self.partial.unlink(missing_ok=True)
            raise ConfigurationError(f"cannot open an MJPG video writer for {path}; use an .avi path.")

    def write(self, frame) -> None:
        self.writer.write(frame)

    def keep(self) -> None:
        self.writer.release()
        os.replace(self.partial, self.path)

    def close(self) -> None:
        self.writer.release()
        self.partial.unlink(missing_ok=True)
