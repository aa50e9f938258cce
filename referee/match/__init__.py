"""The match core.

- `simulation`: one match's world, sensing, task, rules and score; no processes, no files.
- `report`: what a control tick did (`Tick`) and a robot's standing (`RobotReport`).
- `loop`: the match, that simulation played by its controllers (`fleet`) and recorded.
- `views`: what a team is told, the replay's frames and header; `deferral`: replay writes
  put off while controllers compute.
- `rules` (fouls), `tasks` along `paths` (progress), `estimates` (localization), `scoring`,
  `result`, `drawings` (debug drawing budgets).
- `verify` re-runs a recorded match; `warm` compiles the kernels at install.

It imports `arena`, `levels`, `robots.api`, the sandbox and records; nothing from contest,
media, gym or cli, and no controller or toolkit code (the contracts in pyproject.toml).
"""
