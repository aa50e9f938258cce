"""The `laserarena` command line.

- `entry`: the console script; `main`: a command's run and every way it ends, as one line
  and an exit code;
- `arguments`: each command's arguments; `commands`: each command, thin, over the rooms;
- `summary`: the console score table; `starter_kit`: what `laserarena new` writes.

Imports: every other room; nothing imports it.
"""
