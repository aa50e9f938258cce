"""The host's half of the team side, which a team never needs to read.

- `runner`: the controller process; `template`: the pre-imported template it is forked from;
  `seccomp`: its filter; `loading`: how a team's code is found and loaded;
- `protocol`: the wire format both ends speak; `forking`: the fork server's words and status;
- `tracebacks`: a team's traceback, cut after the host's frames.

Imports: what `robots` may (it runs in the team's process).
"""
