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
Name = Annotated[str, msgspec.Meta(max_length=256)]
Point = tuple[Real, Real]
