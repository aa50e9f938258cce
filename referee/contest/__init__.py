"""Many matches: grading teams x levels x seeds and its leaderboard (`grade`), tournaments of
teams racing in heats with their ratings and report (`tournament`, `schedule`, `ratings`,
`report`), all into one resumable journal (`journal`), played as self-contained jobs on this
process, a local pool or a Dask cluster (`runner`, `shipping`), their noise drawn from a
run's secret (`noise_secret`, judged by `secret_strength`).

It may import the match core, the sandbox, the records and `arena`; never media, gym, cli or
`robots` (team code travels as bytes). `dask` is imported here only (pyproject.toml's contracts
hold this).
"""
