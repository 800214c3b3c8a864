"""arena-league: population evaluation and league benchmark service for multi-agent RL."""

__version__ = "0.1.0"
