"""guiding."""
