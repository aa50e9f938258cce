"""The `laserarena` command line: thin argument parsing over the other rooms (`main`), the
console score table (`summary`), and the starter kit that `laserarena new` writes
(`starter_kit`). Every error path ends in `referee.errors`, printed as one line.

It may import every other room; nothing imports it.
"""
