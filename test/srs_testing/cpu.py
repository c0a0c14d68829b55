"""CPU time of the processes a benchmark started, for the figures it prints.

``getrusage(RUSAGE_CHILDREN)`` counts only children this process has reaped itself. The local pool's workers are
forked by a forkserver, a child that outlives the measurement, so they are grandchildren: that count read 0 s for
a sweep that used 3.6 s (a review of the benchmarks). :func:`descendants_cpu_s` adds what each live child has used
and reaped.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def _stat(pid: int) -> list[str] | None:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:  # gone meanwhile
        return None


def descendants_cpu_s() -> float:
    """User + system CPU seconds of this process's children: the reaped ones, and each live child's own and its
    reaped children's (``/proc/<pid>/stat`` utime, stime, cutime, cstime), recursively over live descendants."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = usage.ru_utime + usage.ru_stime
    stats = {int(entry.name): _stat(int(entry.name)) for entry in Path("/proc").iterdir() if entry.name.isdigit()}
    children: dict[int, list[int]] = {}
    for pid, fields in stats.items():
        if fields is not None:
            children.setdefault(int(fields[1]), []).append(pid)  # field 4, the parent's pid
    pending = list(children.get(os.getpid(), []))
    while pending:
        pid = pending.pop()
        fields = stats[pid]
        total += sum(int(v) for v in fields[11:15]) / CLOCK_TICKS  # fields 14-17
        pending += children.get(pid, [])
    return total
