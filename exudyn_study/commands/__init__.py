"""Subcommands of the ``exudyn-study`` console script that are not part of a library subpackage."""
