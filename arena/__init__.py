"""The physical world: levels, physics, drive, laser and detector models, drawing.

Knows nothing of teams or scores.
"""
