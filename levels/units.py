"""Length units accepted by level files, converted to metres on load."""

LENGTH_UNITS: dict[str, float] = {"m": 1.0, "ft": 0.3048, "in": 0.0254}
