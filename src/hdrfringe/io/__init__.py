"""Input and output: capture folders, result folders, map files."""
