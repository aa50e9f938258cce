"""Many matches: grading teams x levels x seeds into a resumable journal on a local pool or a
Dask cluster, and the leaderboard (`grade`).

It may import the match core, the sandbox's team specs and the records; never media or cli.
"""
