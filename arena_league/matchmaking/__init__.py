"""matchmaking layer of arena-league (see DESIGN.md)."""
