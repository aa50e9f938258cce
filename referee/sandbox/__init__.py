"""Team code, kept out of the referee: team specs resolved without running them (`teams`),
a Controller class handed to the Python API made a team that ships its source (`class_source`),
what every controller does for the match (the `Bot` protocol, `bot`) and the `Fault` it reports
(`fault`; the match makes the record of it), one controller process per slot inside its own
kernel sandbox (`process`: started by `launch`, spoken to over a framed `channel`, within its
time `allowance`; the sandbox made by `kernel`, or forked by `forkserver`, from the
installation as `stage` staged it), one tick's exchange with all of them at once (`exchange`),
the in-process call site for debugging (`in_process`), the privilege drop and process hygiene
they rely on (`privacy`), each slot's uid (`uids`) and control groups (`cgroup`), held by
`leases`, its log pipe (`log`), and one CPU shared by a referee and its lone controller
(`affinity`).

How it works, in detail: docs/internals.md, `referee/sandbox/__init__.py`.
"""
