"""Files written whole or not at all: a crash, a full disk or Ctrl-C mid-write leaves the old file as it was."""

from __future__ import annotations

import os
from pathlib import Path


def write_atomically(path: str | Path, text: str | bytes) -> Path:
    """Write a file through a temporary sibling and a rename: it is there whole or not at all."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if isinstance(text, bytes):
            tmp.write_bytes(text)
        else:
            tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
