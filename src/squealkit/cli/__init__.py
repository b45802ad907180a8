"""The ``squealkit`` command line: thin subcommands over the public API."""
