"""A tournament's published files: standings.csv, .json and .md, heats.csv, the replays, and
index.html, a page that needs no network (inline CSS and SVG) with the standings, each team's
rating over the heats, the per-level tables and every heat linked to its replay and its viewer
page (heats/heat-NNNN.html, written by the command line with referee.media.viewer).
"""

from __future__ import annotations

import html
import json
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

from referee.contest.ratings import Rating
from referee.contest.tournaments import HeatResult, Outcome
from referee.terminal import csv_text, markdown_text

ALONE = (
    " On a one-robot level every team plays each round's seed, and the matches on one seed are"
    " ranked and rated together, as one heat."
)
T = TypeVar("T")
PALETTE = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#7f7f7f"]


def replay_file(heat: HeatResult) -> str:
    """A heat's replay, relative to the output folder."""
    return f"replays/heat-{heat.heat.number:04d}.replay"


def viewer_file(heat: HeatResult) -> str:
    """A heat's viewer page, relative to the output folder."""
    return f"heats/heat-{heat.heat.number:04d}.html"


def _name(outcome: Outcome, heat: HeatResult, slot: int) -> str:
    team = heat.heat.teams[slot]
    return outcome.teams[team].name if team is not None else heat.heat.specs[slot]


HEAT_COLUMNS = ("heat", "level", "seed", "slot", "team", "rank", "score", "filler")


def heat_rows(outcome: Outcome) -> list[list]:
    """One row per robot per heat, in heat and slot order, as heats.csv holds them (HEAT_COLUMNS)."""
    return [
        [h.heat.number, h.heat.level, h.heat.seed, slot, _name(outcome, h, slot), p.rank, p.score, int(p.team is None)]
        for h in outcome.heats
        for slot, p in enumerate(h.placings)
    ]


def rating_figures(rating: Rating | None, form: Callable[[float], T]) -> tuple[T | None, T | None, T | None]:
    """A rating's ordinal, mu and sigma each as `form` makes it, or three Nones where no
    rating could be formed (never a zero that looks like one)."""
    if rating is None:
        return None, None, None
    return form(rating.ordinal), form(rating.mu), form(rating.sigma)


def standings_data(outcome: Outcome, notes: Sequence[str] = ()) -> dict:
    """The standings as plain data (standings.json), with the tournament's `notes`."""
    return {
        "notes": list(notes),
        "standings": [
            {
                "rank": s.rank,
                "team": s.team,
                **dict(zip(("rating", "mu", "sigma"), rating_figures(s.rating, lambda v: round(v, 4)))),
                "heats": s.heats,
                "mean_score": s.mean_score,
                "faults": s.faults,
                "levels": {
                    level: {"heats": n, "mean_score": mean, "ci95": [low, high]}
                    for level, (n, mean, low, high) in s.levels.items()
                },
            }
            for s in outcome.standings
        ],
        "heats": len(outcome.heats),
        "model": "openskill PlackettLuce; rating = mu - 3 sigma",
    }


def standings_markdown(outcome: Outcome, title: str, notes: Sequence[str] = ()) -> str:
    """standings.md: the title, the standings as a Markdown table, each of `notes` and each
    team's faults on a line of its own (team names, notes and faults escaped: they render as
    themselves)."""
    md = [
        f"# {markdown_text(title)}",
        "",
        "| rank | team | rating | mu | sigma | heats | mean score |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in outcome.standings:
        rating, mu, sigma = (v or "-" for v in rating_figures(s.rating, "{:.2f}".format))
        md.append(
            f"| {s.rank} | {markdown_text(s.team)} | {rating} | {mu} | {sigma} | {s.heats} | {s.mean_score:.1f} |"
        )
    md += [f"\nNote: {markdown_text(note, 500)}" for note in notes]
    md += [
        f"\nFaults of {markdown_text(s.team)}: {markdown_text(s.faults, 500)}" for s in outcome.standings if s.faults
    ]
    return "\n".join(md) + "\n"


def write(outcome: Outcome, out: Path, title: str, notes: Sequence[str] = ()) -> None:
    """Write every file but the viewer pages into `out` (made if missing); `notes` (a team
    refused, heats played without a sandbox) go into index.html and standings.json."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "replays").mkdir(exist_ok=True)
    (out / "heats").mkdir(exist_ok=True)
    rows = [
        [s.rank, s.team, *(v or "" for v in rating_figures(s.rating, "{:.4f}".format)), s.heats, s.mean_score]
        for s in outcome.standings
    ]
    for row, s in zip(rows, outcome.standings):
        row.append(s.faults)
    (out / "standings.csv").write_text(
        csv_text(["rank", "team", "rating", "mu", "sigma", "heats", "mean_score", "faults"], rows), encoding="utf-8"
    )
    (out / "standings.json").write_text(
        json.dumps(standings_data(outcome, notes), indent=2, sort_keys=True) + "\n", encoding="utf-8"
    )
    (out / "standings.md").write_text(standings_markdown(outcome, title, notes), encoding="utf-8")
    (out / "heats.csv").write_text(csv_text(HEAT_COLUMNS, heat_rows(outcome)), encoding="utf-8")
    wanted = {replay_file(h) for h in outcome.heats} | {viewer_file(h) for h in outcome.heats}
    for old in [*out.glob("replays/heat-*.replay"), *out.glob("heats/heat-*.html")]:
        if old.relative_to(out).as_posix() not in wanted:  # a heat of an earlier, larger tournament
            old.unlink()
    for h in outcome.heats:
        target = out / replay_file(h)
        shutil.copyfile(h.replay, target)
        os.chmod(target, 0o644)  # published: the page and its readers need it
    (out / "index.html").write_text(page(outcome, title, notes), encoding="utf-8")


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def rating_plot(outcome: Outcome, width: int = 720, height: int = 300) -> str:
    """Each team's rating (mu - 3 sigma) after each heat, as an inline SVG line chart."""
    if not outcome.history:
        return ""
    from openskill.models import PlackettLuce

    n = len(outcome.history)
    start = PlackettLuce().rating().ordinal()  # every team's rating before heat 1
    values = [start] + [r.ordinal for step in outcome.history for r in step]
    lo, hi = min(values), max(values)
    if hi - lo < 1e-9:
        hi = lo + 1.0
    left, right, top, bottom = 50, 160, 12, 30
    pw, ph = width - left - right, height - top - bottom

    def x(i: int) -> float:
        return left + pw * i / n

    def y(v: float) -> float:
        return top + ph * (hi - v) / (hi - lo)

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" '
        f'role="img" aria-label="rating over heats">',
        f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>',
    ]
    for k in range(5):
        v = lo + (hi - lo) * k / 4
        parts.append(f'<text x="{left - 4}" y="{y(v) + 4:.1f}" text-anchor="end" font-size="11">{v:.1f}</text>')
        parts.append(f'<line x1="{left}" x2="{left + pw}" y1="{y(v):.1f}" y2="{y(v):.1f}" stroke="#eee"/>')
    parts.append(f'<text x="{left + pw / 2}" y="{height - 6}" text-anchor="middle" font-size="11">heat</text>')
    for i in {0, n // 2, n}:
        parts.append(f'<text x="{x(i):.1f}" y="{top + ph + 14}" text-anchor="middle" font-size="11">{i}</text>')
    for t, entrant in enumerate(outcome.teams):
        colour = PALETTE[t % len(PALETTE)]
        points = [(x(0), y(start))] + [(x(i + 1), y(step[t].ordinal)) for i, step in enumerate(outcome.history)]
        line = " ".join(f"{a:.1f},{b:.1f}" for a, b in points)
        parts.append(f'<polyline fill="none" stroke="{colour}" stroke-width="2" points="{line}"/>')
        ly = top + 14 + 16 * t
        parts.append(f'<rect x="{left + pw + 10}" y="{ly - 9}" width="12" height="4" fill="{colour}"/>')
        parts.append(f'<text x="{left + pw + 26}" y="{ly - 4}" font-size="11">{_e(entrant.name[:22])}</text>')
    parts.append("</svg>")
    return "\n".join(parts)


STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em; color: #222; max-width: 1100px; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border-bottom: 1px solid #ddd; padding: 0.25em 0.7em; text-align: left; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
.filler { color: #888; font-style: italic; }
small { color: #666; }
"""


def page(outcome: Outcome, title: str, notes: Sequence[str] = ()) -> str:
    """index.html: self-contained, no script, no network; each of `notes` in a paragraph."""
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{_e(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f"<p>{len(outcome.teams)} teams, {len(outcome.heats)} heats on "
        f"{_e(', '.join(dict.fromkeys(h.heat.level for h in outcome.heats)))}. Rating: openskill's Plackett-Luce "
        "model, updated heat by heat; teams are ranked by the conservative rating mu - 3 sigma. "
        '<span class="filler">Fillers</span> (the level\'s default controller in a slot no team '
        "fills) are never rated." + (ALONE if any(len(h.placings) == 1 for h in outcome.heats) else "") + "</p>",
        *(f'<p class="note"><strong>Note:</strong> {_e(note)}</p>' for note in notes),
        "<h2>Standings</h2>",
        "<table><tr><th>rank</th><th>team</th><th>rating</th><th>mu</th><th>sigma</th><th>heats</th>"
        "<th>mean score</th></tr>",
    ]
    for s in outcome.standings:
        rating, mu, sigma = (v or "-" for v in rating_figures(s.rating, "{:.2f}".format))
        out.append(
            f'<tr><td class="n">{s.rank}</td><td>{_e(s.team)}</td><td class="n">{rating}</td>'
            f'<td class="n">{mu}</td><td class="n">{sigma}</td>'
            f'<td class="n">{s.heats}</td><td class="n">{s.mean_score:.1f}</td></tr>'
        )
    out.append("</table>")
    out += [f"<p>Faults of {_e(s.team)}: {_e(s.faults)}</p>" for s in outcome.standings if s.faults]
    if not outcome.unrated:  # no chart of ratings that were never formed
        out += ["<h2>Rating over the heats</h2>", rating_plot(outcome)]
    for level in dict.fromkeys(h.heat.level for h in outcome.heats):
        out.append(f"<h2>Level {_e(level)}</h2>")
        out.append("<table><tr><th>team</th><th>heats</th><th>mean score</th><th>95 % interval (bootstrap)</th></tr>")
        rows = [(s.team, s.levels[level]) for s in outcome.standings if level in s.levels]
        for team, (n, mean, low, high) in sorted(rows, key=lambda r: (-r[1][1], r[0])):
            out.append(
                f'<tr><td>{_e(team)}</td><td class="n">{n}</td><td class="n">{mean:.1f}</td>'
                f'<td class="n">{low:.1f} – {high:.1f}</td></tr>'
            )
        out.append("</table>")
    out.append("<h2>Heats</h2>")
    out.append(
        "<table><tr><th>heat</th><th>round</th><th>level</th><th>seed</th><th>slots: team (rank, score)</th>"
        "<th>watch</th></tr>"
    )
    for h in outcome.heats:
        slots = []
        for slot, p in enumerate(h.placings):
            name = _e(_name(outcome, h, slot))
            cls = ' class="filler"' if p.team is None else ""
            slots.append(f"{slot}: <span{cls}>{name}</span> ({p.rank}, {p.score:.1f})")
        out.append(
            f'<tr><td class="n">{h.heat.number}</td><td class="n">{h.heat.round}</td><td>{_e(h.heat.level)}</td>'
            f'<td class="n">{h.heat.seed}</td><td>{"<br>".join(slots)}</td>'
            f'<td><a href="{viewer_file(h)}">viewer</a> · <a href="{replay_file(h)}">replay</a></td></tr>'
        )
    out.append("</table>")
    out.append(
        "<p><small>Given the teams' code, each replay re-simulates bit for bit with <code>laserarena verify</code>.</small></p>"
    )
    out.append("</body></html>")
    return "\n".join(out) + "\n"
