"""replay layer of arena-league (see DESIGN.md)."""
