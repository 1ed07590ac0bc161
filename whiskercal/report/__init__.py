"""The calibration report: figures of one calibration and a self-contained HTML page."""
