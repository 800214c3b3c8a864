"""One module per game; each module docstring is that game's manual."""
