"""The error a malformed scene or render setting raises."""


class SceneError(ValueError):
    """A malformed scene: the message names the field and the problem."""
