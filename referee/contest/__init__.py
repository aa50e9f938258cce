"""Many matches: grading, tournaments, and the journal that makes them resumable.

- `grading` (and its leaderboard), `tournaments` (heats from `schedule`, `ratings`, the
  published `report`), both into the SQLite `journal`;
- matches as self-contained jobs (`runner`, team code as bytes in `shipping`) on this
  process, a local pool or Dask (`dispatch`); noise from a run's secret (`noise_secret`,
  judged by `secret_strength`);
- a Dask cluster named and checked (`cluster`, TLS keys `cluster_keys`), its client in a
  process of its own (`courier`, `courier_link`; started as `nobody` by `courier_box`), each result checked (`received`) and each
  worker audited (`audit`) by `remote`.

Imports: match, sandbox, records, `arena`, `levels`; never `robots` (team code travels as bytes).
"""
