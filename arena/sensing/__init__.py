"""Sensing: every robot's spinning laser against the level's beacons, organised by what each
part computes.

- the sweep's geometry: the lasers' phases (`spin`), exact beam-beacon crossing times and
  index marks (`crossings`), what blocks a beam (`occlusion`);
- the detector kinds, each with its gates, response, noise and compiled loops: `reflector`,
  `sensor_array`, `flash_detector`, `light`; what the finite-beam kinds share (`optics`), what
  every kind's electronics read (`readout`, and `pulses`, the compiled reading of a batch),
  and the level's hardware by kind (`hardware`: ideal parameters, bearing noise, dispatch);
- a batch's hits in two compiled calls (`sweep`), each robot's normal draws in blocks (`normals`);
- the events a controller gets (`events`), and the pipeline that calls each part once per
  control tick, in order (`pipeline`: `Sensing`).

Imports: the rest of `arena` and `levels`; nothing of teams or scores.
"""
