"""Showing what happened: scenes and video from replays (`render`), the live window (`watch`),
the browser viewer (`viewer`, its page in `web/`), error plots (`plot`, `error_series`), the
score so far (`standings`), and beacon-layout accuracy maps (`accuracy_map`).

It may import `arena` (drawing, levels), the records and the match core (its scoring rules;
`watch` of a level plays through its loop, and resolves the teams it is given with
`sandbox.teams`); of `robots`, only the toolkit's association, for accuracy maps. It runs no
controller except through the match core (pyproject.toml's contracts hold this).
"""
