"""The physical world: physics, drive, lasers and detectors, placement, drawing.

- `world`: the pymunk space and its robots; `chipmunk`: pymunk's private parts, in one place;
  `stepping`: a run of physics steps in one compiled loop; `drive`: the drive and its errors.
- `sensing`: the lasers against the beacons; `floor`: the tiles a trial is set down on;
  `placement`: where robots really start; `rng`: the match's random tree; `angles`.
- `draw`: one moment of a match, drawn; `compiled`: loops compiled with NumPy's bits (`_numba`:
  numba's side; `_machine`: their machine code run without numba; `_elf`: the symbols it
  defines); `heap`: what a process keeps, out of the collector's way.

Imports: `levels`; nothing of teams or scores.
"""
