"""The physical world: levels, physics, drive, the lasers and detectors (`sensing/`), drawing;
loops compiled with NumPy's bits (`compiled`).

Knows nothing of teams or scores.
"""
