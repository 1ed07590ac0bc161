"""One module per ``whiskercal`` subcommand; each defines ``command``."""
