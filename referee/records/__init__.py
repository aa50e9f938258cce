"""What a match leaves behind: the result and the replay.

- `canonical`: canonical JSON; `results`: the typed result records; `result_schema`: their
  published JSON Schema; `faults`: a robot's faults told in a line, where in its code included;
- `replay_format`: the replay's header and in-memory form; `replay_lines`: its hot lines,
  formatted by hand; `decimals`: their floats in one compiled call;
- `replay_writer`: the writer and the in-memory recorder; `replay_reader`: the reader.

Imports: `referee.errors`, `levels`, `arena.compiled` (in `decimals` only): anything may read a record.
"""
