"""Binaural ears of another package: a component with its own settings, audio port, port kind and capture backend.

Nothing here is aiogenomix's: the package declares in its ``pyproject.toml`` the entry points
through which the gateway finds each piece (``aiogenomix.components``, ``aiogenomix.settings``,
``aiogenomix.capture_backends``, ``aiogenomix.port_kinds``), as docs/writing_a_component.md shows.
"""

from ._ears import EARS_DEVICE, Block, Ears, EarsSettings, Held, Level, Loudness
from ._tone import ToneBackend

__all__ = ["Ears", "EarsSettings", "Block", "Held", "Level", "Loudness", "EARS_DEVICE", "ToneBackend"]
