"""What the mock backend of a node in another process really wrote: its ``record_file``, read as it grows."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def recorded_rig(folder: Path, name: str = "recorded", **options: Any) -> tuple[Path, Path]:
    """The shipped mock rig with every command its backend is given appended to a file: (rig file, record file).

    ``options`` are more backend_options (e.g. ``fail_after_writes=400``).
    """
    import yaml

    from srs_ros.core.rig import default_rig_path

    record = Path(folder) / f"{name}_writes.txt"
    data = yaml.safe_load(default_rig_path().read_text())
    data["rig"]["backend_options"].update(record_file=str(record), **options)
    rig = Path(folder) / f"{name}.yaml"
    rig.write_text(yaml.safe_dump(data))
    return rig, record


class BackendRecord:
    """The commands a mock backend in another process wrote, read on as the file grows (:meth:`update`)."""

    def __init__(self, path: Path):
        import numpy as np

        self.path = Path(path)
        self.times_s = np.zeros(0)
        self.pressures_bar = np.zeros((0, 9))
        self._offset = 0

    def update(self) -> BackendRecord:
        import numpy as np

        from srs_ros.backends.mock import read_record

        if self.path.exists():
            times, pressures, self._offset = read_record(self.path, self._offset)
            if times.size:
                self.times_s = np.concatenate([self.times_s, times])
                self.pressures_bar = np.concatenate([self.pressures_bar, pressures])
        return self

    def __len__(self) -> int:
        return self.update().times_s.size

    def last(self):
        """The newest command (bar), or None before the first."""
        return self.pressures_bar[-1] if len(self) else None

    def commanding(self, expected_bar, atol: float = 1e-9) -> bool:
        import numpy as np

        last = self.last()
        return last is not None and bool(np.allclose(last, expected_bar, atol=atol))

    def vented(self) -> bool:
        last = self.last()
        return last is not None and not last.any()


class ManualClock:
    """A mock backend's clock (``MockBackend(clock=...)``), advanced only by :meth:`sleep`: a run takes no wall time.

    Pass ``sleep`` as the waits of the code under test (e.g. ``BackendIO(backend, clock, clock.sleep)``).
    """

    def __init__(self, start_s: float = 50.0):
        self.now_s = start_s

    def __call__(self) -> float:
        return self.now_s

    def sleep(self, seconds: float) -> None:
        self.now_s += seconds
