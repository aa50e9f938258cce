"""Showing what happened: video, the live window, the browser viewer, plots and maps.

- `render`: scenes, PNG and MP4 from replays; `watch`: the live window; `viewer`: the
  browser page (its script in `web/`);
- `plot` and `error_series`: error plots; `standings`: the score so far;
  `accuracy_map`: where a beacon layout localizes well.

Imports: match, records, `arena`, `levels`; `sandbox.teams` in `watch`, the toolkit's
association in `accuracy_map` only.
"""
