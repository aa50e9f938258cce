"""The `laserarena` command line: the process's first and last code (`entry`: an interrupt
before the command's own handler is in place; the end without teardown), the entry point and
its exits (`main`), each command's arguments (`arguments`) and its thin implementation over
the other rooms (`commands`), the console score table (`summary`), and the starter kit that
`laserarena new` writes (`starter_kit`). Every error path ends in `referee.errors`, printed
as one line.

It may import every other room; nothing imports it.
"""
