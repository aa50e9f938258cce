"""What a match leaves behind: canonical JSON (`canonical`), the replay writer and reader
(`replay`), and the typed result records and their JSON Schema (`results`).

It may import `arena.level` (a replay carries its level) and `referee.errors`; never the match
loop, the sandbox, contest, media or cli, so anything may read a record.
"""
