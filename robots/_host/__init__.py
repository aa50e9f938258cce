"""The host's half of the team side, which a team never needs to read: the controller process
(`runner`), the pre-imported template it is forked from (`template`), the seccomp filter
(`seccomp`), how a team's code is found and loaded (`loading`), and the wire format both ends
speak (`protocol`). It runs in the team's process, so it imports nothing of `levels`, `arena`
or `referee`.
"""
