"""Argument checks shared by the core: arrays of the right shape, finite, with errors that say so.

Scalars, config keys and option tables are checked by :mod:`srs_ros.core.schema`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from srs_ros.core.errors import InvalidInputError


def _shape_text(tail: Sequence[int | None]) -> str:
    return "(..., " + ", ".join("n" if t is None else str(t) for t in tail) + ")" if tail else "(...)"


def finite_array(name: str, value, tail: Sequence[int | None] = (), unit: str = "",
                 min_ndim: int | None = None) -> np.ndarray:
    """Return ``value`` as a float64 array whose last dimensions are ``tail``, all finite.

    ``None`` in ``tail`` accepts any size there. Raises :class:`InvalidInputError` saying which
    argument, what shape was expected and what was given, or where the NaN/inf is.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name}: expected numbers{unit and ' in ' + unit}, got {value!r} ({exc}).") from None
    ndim = len(tail) if min_ndim is None else min_ndim
    shape_ok = array.ndim >= ndim and all(
        want is None or got == want for want, got in zip(tail[::-1], array.shape[::-1])
    )
    if not shape_ok:
        raise InvalidInputError(
            f"{name}: expected an array of shape {_shape_text(tail)}{unit and ' in ' + unit}, "
            f"got shape {array.shape}."
        )
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise InvalidInputError(
            f"{name}: every value must be finite, got {array[tuple(bad)]} at index {tuple(int(i) for i in bad)}."
        )
    return array

