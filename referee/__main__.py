"""`python -m referee` is the `laserarena` command."""

from referee.cli.main import main

raise SystemExit(main())
