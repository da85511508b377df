"""GidaBot navigation package."""
