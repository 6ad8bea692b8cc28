"""Example data shipped with loadpath: the open-hole tensile specimen and its load case."""
