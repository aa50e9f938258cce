"""The physical world: physics, drive, the lasers and detectors (`sensing/`), where robots are
set down, drawing; loops compiled with NumPy's bits (`compiled`).

Reads levels through the level model below it (`levels`); knows nothing of teams or scores.
"""
