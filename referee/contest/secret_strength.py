"""How strong a noise secret is: the bits an attacker's guessing would have to cover, and the
bound every secret must reach (docs/integrity.md, "How a secret is judged").

zxcvbn, a maintained password-strength estimator, prices a text by the guesses an attacker
needs who tries words, names, years, dates, keyboard walks, repeats, sequences and l33t
spellings before brute force. It prices each character it finds no pattern in at log2(10),
about 3.3 bits: right for typed text, too little for a random token, whose hex digit holds
4 bits and base64 character 6. So a token written only in the base64 or hex alphabets, in
which zxcvbn finds no more structure than chance leaves in a random token, counts at its
capacity: its length times log2 of its alphabet. Anything else counts as zxcvbn prices it.
"""

from __future__ import annotations

import math
import string

MIN_BITS = 128  # a secret must reach this (docs/integrity.md)
JUDGED = 72  # zxcvbn judges at most this many characters; only these count, never the rest
CHANCE = 0.8  # a random token's zxcvbn price is at least 0.85 of a patternless one's (measured)

HEX = (frozenset("0123456789abcdef"), frozenset("0123456789ABCDEF"))
BASE64 = (
    frozenset(string.ascii_letters + string.digits + "-_"),
    frozenset(string.ascii_letters + string.digits + "+/"),
)
CLASSES = (frozenset(string.digits), frozenset(string.ascii_lowercase), frozenset(string.ascii_uppercase))


def _alphabet(token: str) -> int | None:
    """The size of the alphabet a random token written so was drawn from: 16 for hex with a
    letter in it, else the classes of base64 it uses (digits 10, lower and upper case letters
    26 each, its two symbols 2); None for text outside those alphabets (typed text)."""
    chars = set(token.rstrip("="))
    if not chars:
        return None
    if any(chars <= h for h in HEX) and chars - set(string.digits):
        return 16
    if not any(chars <= b for b in BASE64):
        return None
    return sum(len(c) for c in CLASSES if chars & c) + (2 if chars - set(string.ascii_letters + string.digits) else 0)


def strength(secret: str) -> tuple[float, str]:
    """The secret's strength in bits, and zxcvbn's warning about it ('' when it has none).
    Only its first JUDGED characters count: a longer secret is at least as strong as them."""
    from zxcvbn import zxcvbn

    judged = secret[:JUDGED]
    verdict = zxcvbn(judged)
    typed = verdict["guesses_log10"] * math.log2(10)
    alphabet = _alphabet(judged)
    patternless = len(judged) * math.log2(10)  # zxcvbn's price of a text it finds no pattern in
    if alphabet is not None and typed >= CHANCE * patternless:
        return len(judged.rstrip("=")) * math.log2(alphabet), ""
    return typed, verdict["feedback"]["warning"]


def weakness(secret: str) -> str | None:
    """Why `secret` is too weak to be a noise secret, in a few words that never quote it; None
    if it reaches MIN_BITS."""
    bits, warning = strength(secret)
    if bits >= MIN_BITS:
        return None
    hint = f"; zxcvbn: {warning[:1].lower()}{warning[1:].rstrip('.')}" if warning else ""
    return f"a weak secret (about {bits:.0f} bits, at least {MIN_BITS} needed{hint})"
