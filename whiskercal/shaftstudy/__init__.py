"""The shaft study: a rod pressed onto the shaft at radial distances and slid (run), and the
shaft localizer judged on it against the twin's truth (report). docs/shaft.md."""
