"""One control tick's exchange with every controller at once: every observation goes out
before any answer is awaited, so controller processes compute side by side while the referee
does work of its own (docs/decisions/0020-controllers-forked-from-a-sandboxed-template.md)."""

from __future__ import annotations

import select
import time
from collections.abc import Callable, Sequence

from referee.records.results import Fault
from referee.sandbox.bot import Awaited, Bot, Reply
from referee.sandbox.channel import Trouble
from robots.api import Command, Observation


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
    waiting: dict[int, Awaited] = {}
    for slot, (bot, obs) in enumerate(zip(bots, observations)):
        if obs is None:
            continue
        sent = bot.send(obs)
        if isinstance(sent, Command | Fault):  # answered at once (in this process), or gone
            out[slot] = sent
        else:
            waiting[slot] = sent
    awaited = dict(waiting)  # (`waiting` loses each as it answers)
    replies: dict[int, Reply] = {}
    if meanwhile is not None and waiting:
        began = time.monotonic()
        meanwhile()
        replies.update(_arrived(waiting, began))
    replies.update(_gathered(waiting))
    for slot in sorted(replies):
        obs = observations[slot]
        assert obs is not None
        out[slot] = awaited[slot].judge(obs, *replies[slot])
    return out


def _channels(waiting: dict[int, Awaited]) -> dict[int, int]:
    """Each waiting bot's output descriptor, and its slot."""
    return {bot.reader(): slot for slot, bot in waiting.items()}


def _arrived(waiting: dict[int, Awaited], began: float) -> dict[int, Reply]:
    """The answers that came in while the referee was busy since `began`, timed to `began`: the
    referee, not the controller, kept them waiting (later answers are timed as always). Their
    bots leave `waiting`."""
    replies: dict[int, Reply] = {}
    readers = _channels(waiting)
    for fd in select.select(list(readers), [], [], 0)[0]:
        slot = readers[fd]
        bot = waiting[slot]
        if not bot.read_more(began):
            replies[slot] = (Trouble.CRASH, max(0.0, began - bot.sent))
        elif bot.answered():
            replies[slot] = bot.decoded()
        else:
            continue
        del waiting[slot]
    return replies


def _gathered(waiting: dict[int, Awaited]) -> dict[int, Reply]:
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
            if bot is None or not bot.answered():
                continue
            if bot.writer() is not None:  # an answer to an observation it has not read
                bot.refuse("it answers without reading its observations")
                replies[slot] = (Trouble.PROTOCOL, time.monotonic() - bot.sent)
            else:
                busy = time.monotonic() if busy is None else busy
                replies[slot] = bot.decoded()
            del waiting[slot], readers[bot.reader()]
        if not waiting:
            break
        writers = {fd: slot for slot, bot in waiting.items() if (fd := bot.writer()) is not None}
        ready: list[int] = select.select(list(readers), [], [], 0)[0] if busy is not None else []
        if ready and busy is not None:
            stamp = busy  # it came while the referee was decoding
        else:
            now = time.monotonic()
            for slot, bot in list(waiting.items()):
                if now >= bot.deadline:
                    unread = bot.writer() is not None
                    if unread:  # its input still full of observations: it answers without reading them
                        bot.refuse("it does not read its observations")
                    replies[slot] = (Trouble.PROTOCOL if unread else Trouble.TIMEOUT, now - bot.sent)
                    del waiting[slot], readers[bot.reader()]
            if not waiting:
                break
            left = min(bot.deadline for bot in waiting.values()) - now
            wait = None if left == float("inf") else max(left, 0.0)
            writable = [fd for fd in writers if waiting.get(writers[fd]) is not None]
            ready, can_write, _ = select.select(list(readers), writable, [], wait)
            stamp = time.monotonic()
            for fd in can_write:
                slot = writers[fd]
                trouble = waiting[slot].write_more()
                if trouble is not None:  # its input closed: it ended
                    replies[slot] = (trouble, stamp - waiting[slot].sent)
                    del readers[waiting[slot].reader()], waiting[slot]
        fresh = []
        for fd in ready:
            if readers.get(fd) is None:
                continue
            slot = readers[fd]
            bot = waiting[slot]
            if not bot.read_more(stamp):
                replies[slot] = (Trouble.CRASH, time.monotonic() - bot.sent)
                del waiting[slot], readers[fd]
            else:
                fresh.append(slot)
    return replies
