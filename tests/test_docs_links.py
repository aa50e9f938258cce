"""Every link of the README and the docs leads somewhere: a relative link resolves to a file
of the checkout (and its `#anchor`, where given, to a heading of that page); a page named in
prose as `docs/NAME.md` exists; and every page of docs/ is listed in the docs' index, every
decision record in the records' index."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
NAMED = re.compile(r"(?<![\w/.-])(docs/[\w./-]+\.(?:md|json|png))")


def anchors(page: Path) -> set[str]:
    """GitHub's anchors of a page's headings."""
    out = set()
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            title = line.lstrip("#").strip().lower()
            out.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
    return out


def links() -> list[tuple[Path, str]]:
    return [(page, m[1]) for page in PAGES for m in LINK.finditer(page.read_text(encoding="utf-8"))]


def test_every_relative_link_resolves():
    found = links()
    assert len(found) >= 60
    broken = []
    for page, target in found:
        if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not broken, "links that lead nowhere:\n" + "\n".join(broken)


def test_every_page_named_in_prose_exists():
    missing = [
        f"{page.relative_to(ROOT)}: {name}"
        for page in PAGES
        for name in NAMED.findall(page.read_text(encoding="utf-8"))
        if not (ROOT / name.rstrip(".")).exists()
    ]
    assert not missing, "pages named that do not exist:\n" + "\n".join(missing)


def test_the_indexes_list_every_page_and_every_record():
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    listed = {target.partition("#")[0] for target in LINK.findall(index)}
    pages = {p.name for p in (ROOT / "docs").glob("*.md")} - {"index.md"}
    assert pages - listed == set(), f"pages the docs' index does not list: {sorted(pages - listed)}"
    records = (ROOT / "docs" / "decisions" / "README.md").read_text(encoding="utf-8")
    listed = set(LINK.findall(records))
    files = {p.name for p in (ROOT / "docs" / "decisions").glob("[0-9]*.md")}
    assert files == listed, (
        f"records not indexed: {sorted(files - listed)}; indexed, not there: {sorted(listed - files)}"
    )
    numbered = re.compile(r"- (\d{4}) \[[^\]]+\]\(\1-[\w-]+\.md\)$")
    assert all(numbered.match(line.rstrip()) for line in records.splitlines() if line.startswith("- ")), (
        "each record's line is its number and its linked title"
    )


def test_the_readme_leads_to_the_three_paths_and_the_indexes():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = set(LINK.findall(readme))
    assert {"docs/controllers.md", "docs/contests.md", "docs/rl.md"} <= targets
    assert {"docs/index.md", "docs/decisions/README.md", "docs/performance.md"} <= targets


def test_the_checker_sees_a_broken_link(tmp_path):
    page = tmp_path / "a.md"
    page.write_text("# A b\n\n[x](missing.md) [y](a.md#a-b) [z](a.md#nowhere)\n")
    assert [t for _, t in [(page, m[1]) for m in LINK.finditer(page.read_text())]] == [
        "missing.md",
        "a.md#a-b",
        "a.md#nowhere",
    ]
    assert "a-b" in anchors(page) and "nowhere" not in anchors(page)
