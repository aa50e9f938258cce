"""The bounds of what crosses the process border: every number finite and within `LIMIT`,
every count, text and list of a bounded size. The API's types (`robots.api`) carry them in
their annotations, so the protocol decodes a team's bytes into a bounded shape whatever arrives."""

from __future__ import annotations

from typing import Annotated

import msgspec

LIMIT = 1e6  # no number in a message may exceed this in size (m, s, rad, m/s)

Real = Annotated[float, msgspec.Meta(ge=-LIMIT, le=LIMIT)]
Size = Annotated[float, msgspec.Meta(ge=0, le=LIMIT)]  # a length or spread: never negative
Count = Annotated[int, msgspec.Meta(ge=0, le=1 << 40)]
Byte = Annotated[int, msgspec.Meta(ge=0, le=255)]
NAME_CHARS = 256
Name = Annotated[str, msgspec.Meta(max_length=NAME_CHARS)]
Point = tuple[Real, Real]

# A command's debug drawings: what the team side sends is within these (it folds or drops the
# rest, naming why), so the referee's bound on an answer's bytes follows from them
MAX_DRAWINGS, MAX_POINTS, MAX_TEXT = 256, 64, 80
KIND_CHARS = 16  # a drawing's kind: point, line, circle, text (or `dropped`, the team side's note)
Kind = Annotated[str, msgspec.Meta(max_length=KIND_CHARS)]
