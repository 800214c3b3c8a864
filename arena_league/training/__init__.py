"""training layer of arena-league (see DESIGN.md)."""
