"""Base populations: the build (train, round robin, select, rate, freeze), its recipes and selection."""
