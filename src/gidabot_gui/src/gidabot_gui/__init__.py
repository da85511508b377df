"""GidaBot gui package."""
