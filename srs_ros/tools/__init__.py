"""Command-line tools of srs_ros (trajectory export, tracking, calibration, wiring check)."""
