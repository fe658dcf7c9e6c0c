"""Private helpers shared by every layer: progress bars and atomic writes."""
