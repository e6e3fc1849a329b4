"""``hil falsify``: a search of a scenario's ranges for the flight that fails (docs/falsify.md)."""
