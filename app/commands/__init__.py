"""One module per ``seedtrack`` subcommand, each with ``add_parser`` and ``run``."""
