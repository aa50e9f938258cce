"""One control tick's exchange with every controller at once: every observation goes out
before any answer is awaited, so controller processes compute side by side while the referee
does work of its own (docs/decisions/0020-controllers-forked-from-a-sandboxed-template.md)."""

from __future__ import annotations

import select
import time
from collections.abc import Callable, Sequence

from referee.sandbox.bot import Bot
from referee.sandbox.channel import Trouble
from referee.sandbox.fault import Fault
from referee.sandbox.process import ProcessBot
from robots import protocol
from robots.api import Command, Observation

Reply = tuple[protocol.Message | Trouble, float]  # an answer (or trouble) and the seconds it took


def exchange(
    bots: Sequence[Bot], observations: Sequence[Observation | None], meanwhile: Callable[[], None] | None = None
) -> list[Command | Fault | None]:
    """Every bot's answer to its observation (None where it has none), as `step` gives it. All
    observations go out before any answer is awaited, so controller processes compute at the
    same time, while this process does `meanwhile` (work of its own that needs no answer); an
    observation a controller's input does not take at once is written as it does, while the
    others' answers are gathered. Each answer is timed from its own sending to its own
    arrival; one that arrived while the referee was busy with `meanwhile`, to when that work
    began."""
    out: list[Command | Fault | None] = [None] * len(bots)
    waiting: dict[int, ProcessBot] = {}
    for slot, (bot, obs) in enumerate(zip(bots, observations)):
        if obs is None:
            continue
        if not isinstance(bot, ProcessBot):
            out[slot] = bot.step(obs)  # a controller in this process answers at once
        elif fault := bot.send(obs):
            out[slot] = fault
        else:
            waiting[slot] = bot
    replies: dict[int, Reply] = {}
    if meanwhile is not None and waiting:
        began = time.monotonic()
        meanwhile()
        replies.update(_arrived(waiting, began))
    replies.update(_gathered(waiting))
    for slot in sorted(replies):
        obs, bot = observations[slot], bots[slot]
        assert obs is not None and isinstance(bot, ProcessBot)
        out[slot] = bot.judge(obs, *replies[slot])
    return out


def _channels(waiting: dict[int, ProcessBot]) -> dict[int, int]:
    """Each waiting bot's output descriptor, and its slot."""
    return {bot.channel.fileno(): slot for slot, bot in waiting.items()}


def _judged(bot: ProcessBot) -> Reply:
    """The answer `bot` has read whole, decoded, and the seconds it took: from its observation's
    sending to its arrival, plus its decoding (the bytes it sent cost the referee that long)."""
    channel = bot.channel
    arrived = channel.arrived
    began = time.monotonic()
    got = channel.message()
    assert got is not None and arrived is not None
    return got, max(0.0, arrived - bot.sent) + time.monotonic() - began


def _arrived(waiting: dict[int, ProcessBot], began: float) -> dict[int, Reply]:
    """The answers that came in while the referee was busy since `began`, timed to `began`: the
    referee, not the controller, kept them waiting (later answers are timed as always). Their
    bots leave `waiting`."""
    replies: dict[int, Reply] = {}
    readers = _channels(waiting)
    for fd in select.select(list(readers), [], [], 0)[0]:
        slot = readers[fd]
        bot = waiting[slot]
        if not bot.channel.read(max(began, bot.sent)):
            replies[slot] = (Trouble.CRASH, max(0.0, began - bot.sent))
        elif bot.channel.whole():
            replies[slot] = _judged(bot)
        else:
            continue
        del waiting[slot]
    return replies


def _gathered(waiting: dict[int, ProcessBot]) -> dict[int, Reply]:
    """Every waiting bot's answer, or its trouble (`timeout` at its own deadline). An answer is
    timed to when the referee could first have seen it: the end of its wait in select(), or,
    for one found at once after the referee decoded another's answer, the start of that work
    (no deadline is judged before what came meanwhile is read)."""
    replies: dict[int, Reply] = {}
    readers = _channels(waiting)  # a bot's entry leaves with it
    fresh = list(waiting)  # the bots that may have an answer whole: all at first, then those just read
    while waiting:
        busy = None  # when the referee began decoding answers in this round
        for slot in fresh:
            bot = waiting.get(slot)
            if bot is None or not bot.channel.whole():
                continue
            if bot.unsent:  # an answer to an observation it has not read
                bot.channel.problem = "it answers without reading its observations"
                replies[slot] = (Trouble.PROTOCOL, time.monotonic() - bot.sent)
            else:
                busy = time.monotonic() if busy is None else busy
                replies[slot] = _judged(bot)
            del waiting[slot], readers[bot.channel.fileno()]
        if not waiting:
            break
        writers = (
            {bot.channel.stdin.fileno(): slot for slot, bot in waiting.items() if bot.unsent}
            if any(bot.unsent for bot in waiting.values())
            else {}
        )
        ready: list[int] = select.select(list(readers), [], [], 0)[0] if busy is not None else []
        if ready and busy is not None:
            stamp = busy  # it came while the referee was decoding
        else:
            now = time.monotonic()
            for slot, bot in list(waiting.items()):
                if now - bot.sent >= bot.limits.step_deadline:
                    if bot.unsent:  # its input still full of observations: it answers without reading them
                        bot.channel.problem = "it does not read its observations"
                    replies[slot] = (Trouble.PROTOCOL if bot.unsent else Trouble.TIMEOUT, now - bot.sent)
                    del waiting[slot], readers[bot.channel.fileno()]
            if not waiting:
                break
            left = min(bot.sent + bot.limits.step_deadline for bot in waiting.values()) - now
            wait = None if left == float("inf") else max(left, 0.0)
            writable = [fd for fd in writers if waiting.get(writers[fd]) is not None]
            ready, can_write, _ = select.select(list(readers), writable, [], wait)
            stamp = time.monotonic()
            for fd in can_write:
                slot = writers[fd]
                rest = waiting[slot].channel.write_now(waiting[slot].unsent)
                if isinstance(rest, Trouble):  # its input closed: it ended
                    replies[slot] = (rest, stamp - waiting[slot].sent)
                    del readers[waiting[slot].channel.fileno()], waiting[slot]
                else:
                    waiting[slot].unsent = rest
        fresh = []
        for fd in ready:
            if readers.get(fd) is None:
                continue
            slot = readers[fd]
            bot = waiting[slot]
            if not bot.channel.read(max(stamp, bot.sent)):
                replies[slot] = (Trouble.CRASH, time.monotonic() - bot.sent)
                del waiting[slot], readers[fd]
            else:
                fresh.append(slot)
    return replies
