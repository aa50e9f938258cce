"""What a match leaves behind: canonical JSON (`canonical`), the typed result records
(`results`) and their published JSON Schema (`result_schema`), and the replay: its format,
header and in-memory form (`replay_format`), its hot lines formatted by hand (`replay_lines`) and their floats in one compiled call
(`decimals`),
the writer and the in-memory recorder (`replay_writer`), and the reader (`replay_reader`).

It may import `referee.errors`, `levels.schema_file` for the schema's one text form
(`result_schema` only) and `arena.compiled` for the compiling policy (`decimals` only); never `arena`'s world, the match loop, the sandbox, contest, media or
cli, so anything may read a record. A replay's header is plain data its caller builds.
"""
