"""The command line: one module per subcommand; the only layer that prints."""
