"""The version of vfrs (kept apart so that modules on every floor can read it)."""

__version__ = "0.1.0"
