"""`python -m referee` is the `laserarena` command."""

from referee.cli.entry import run

run()
