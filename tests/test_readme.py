"""The README names what the code has: every reference controller a team spec `ref:NAME` can
run, and none that it cannot."""

import re
from pathlib import Path

from robots.controllers import REFERENCE

README = Path(__file__).resolve().parent.parent / "README.md"


def test_the_readme_lists_every_reference_controller():
    text = README.read_text(encoding="utf-8")
    listed = text[text.index("(a reference controller:") :]
    names = re.findall(r"`([\w-]+)`", listed[: listed.index("),")])
    assert sorted(names) == sorted(REFERENCE), "README's ref: list differs from robots.controllers.REFERENCE"
