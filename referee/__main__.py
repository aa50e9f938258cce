"""`python -m referee` is the `laserarena` command."""

from referee.cli import main

raise SystemExit(main())
