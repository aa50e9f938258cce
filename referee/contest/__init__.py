"""Many matches: grading teams x levels x seeds and its leaderboard (`grading`), tournaments of
teams racing in heats with their ratings and report (`tournaments`, `schedule`, `ratings`,
`report`), all into one resumable journal (`journal`), played as self-contained jobs
(`runner`, `shipping`) on this process, a local pool or a Dask cluster (`dispatch` says
which), their noise drawn from a
run's secret (`noise_secret`, judged by `secret_strength`).

A Dask cluster is named and checked by `cluster` (TLS with the organizer's keys from
`cluster_keys`, or an insecure `tcp://` the organizer accepted); its client lives in a process
of its own (`courier`, spoken to over `courier_link`), so the organizer's process never loads
what a worker sends; `remote` checks each result against its job (`received`) and audits each
worker by playing a share of its matches again here (`audit`).

How it works, in detail: docs/internals.md, `referee/contest/__init__.py`.
"""
