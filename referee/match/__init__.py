"""The match core: the lockstep loop, the turn pipeline alone (`loop`); its controllers from
launch to close (`fleet`); what a team is told, the replay's frames and its header (`views`);
the replay writes put off while controllers compute (`deferral`); the rules that call fouls
(`rules`, the field's border check compiled), a controller's fault as the result records it
(`faults`), task progress (`tasks`) along the ideal path (`paths`), localization accuracy
(`estimates`), the score (`scoring`) and the result assembled from them (`result`);
re-running a recorded match to check it (`verify`); and the compiled kernels readied at
install by short matches (`warm`).

It may import `arena` (the world it referees), `robots.api` and `robots._host.protocol` (the
messages a controller exchanges), the sandbox (to run controllers) and records (to write
replays); nothing from contest, media, gym or cli, and no controller or toolkit code
(pyproject.toml's contracts hold this).
"""
