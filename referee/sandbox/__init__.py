"""Team code, kept out of the referee: each controller in a kernel sandbox of its own.

- `teams`: team specs resolved without running them (`team_files`; a Controller class ships
  its source, `class_source`);
- `bot`: the `Bot` protocol every controller serves; `fault`: its faults as the result
  records them; `exchange`: one tick's exchange with all at once; `in_process`: the
  debugger's call site;
- `process`: a controller process, started by `launch` (forked by `forkserver`, or a bwrap
  sandbox of `kernel`'s, from the installation `stage` staged), spoken to over `channel`,
  within its time `allowance`; `exits`: a child's end, seen as it comes;
- `privacy`: the privilege drop; `uids`, `cgroup` and `log`: each slot's user, control groups
  and log pipe, held by `leases`; `affinity`: one CPU for a referee and its lone controller.

Imports: `robots` (not its toolkit), `levels`, records, `referee.errors`, `referee.terminal`.
"""
