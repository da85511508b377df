"""GidaBot sim package."""
