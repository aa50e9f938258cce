"""Real hostile controllers, one per attack class, each contained by the sandbox."""
