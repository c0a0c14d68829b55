"""Fake ``nidaqmx.types``: the watchdog named tuples (same fields as NI's)."""

import collections

AOExpirationState = collections.namedtuple("AOExpirationState", ["physical_channel", "expiration_state", "output_type"])
