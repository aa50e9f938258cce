"""Showing what happened: scenes and video from replays (`render`), the live window (`watch`),
the browser viewer (`viewer`, its page in `web/`), error plots (`plot`, `error_series`), the
score so far (`standings`), and beacon-layout accuracy maps (`accuracy_map`).

It may import `arena` (drawing, levels), the records and the match core's scoring rules; it
runs no controller except through the match core (`watch` of a level).
"""
