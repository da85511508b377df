"""navstack."""
