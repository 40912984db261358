"""The error a malformed scene or render setting raises, and the escaping
that keeps what came from a file or a key readable and harmless in a
message."""

import unicodedata


def escaped(text: str) -> str:
    """``text`` with every character that a terminal would not show as
    itself (control characters such as ESC, NUL or a newline, and Unicode
    format characters such as a zero-width space or a right-to-left
    override) written as its escape (``\\x1b``, ``\\u200b``)."""
    if text.isprintable() and not any(unicodedata.category(ch) == "Cf" for ch in text):
        return text
    return "".join(ch if ch.isprintable() and unicodedata.category(ch) != "Cf" else ascii(ch)[1:-1] for ch in text)


class SceneError(ValueError):
    """A malformed scene: the message names the field and the problem. Its
    text is :func:`escaped`: keys, file names and values from a scene reach
    a terminal or a log only as visible characters."""

    def __init__(self, message: str = "") -> None:
        super().__init__(escaped(str(message)))
