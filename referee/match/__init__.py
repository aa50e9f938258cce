"""The match core: one match simulated, played by its controllers and recorded.

- `simulation`: one match's world, sensing, task, rules and score; no processes, no files.
- `report`: what a control tick did (`Tick`) and a robot's standing (`RobotReport`).
- `loop`: the match, that simulation played by its controllers (`fleet`) and recorded.
- `views`: what a team is told, the replay's frames and header; `deferral`: replay writes
  put off while controllers compute.
- `rules` (fouls), `tasks` along `paths` (progress), `estimates` (localization), `scoring`,
  `result`, `drawings` (debug drawing budgets).
- `verify` re-runs a recorded match; `warm` compiles the kernels at install.

Imports: sandbox, records, `arena`, `levels`, `robots.api` and `robots._host.protocol`;
never a controller or the toolkit.
"""
