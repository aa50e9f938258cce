"""Team code, kept out of the referee: team specs resolved without running them (`teams`), a
Controller class handed to the Python API made a team that ships its source (`class_source`),
one controller process per slot inside its own kernel sandbox (`process`), the in-process call
site for debugging (`bot`), the privilege drop and process hygiene they rely on (`privacy`),
each slot's control group (`cgroup`) and log pipe (`log`), and one CPU shared by a referee and
its lone controller (`affinity`).

It may import `robots.api` and `robots.protocol` (the border's messages) and `referee.errors`;
never the match, records, contest, media or cli.
"""
