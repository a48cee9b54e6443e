"""The exception tree of the audio library (backends, scenes, the dedicated sockets).

::

    AudioError                                 anything the audio library refuses or fails at
    ├── DeviceNotFound (LookupError)           no such sound device; says what exists
    ├── UnknownDevicePrefix (ValueError)       a device PREFIX: that no backend has; says which do
    ├── BackendUnavailable (ImportError)       the backend's library is not installed
    ├── DeviceError (OSError)                  the device failed while open or opening
    │   └── FormatRefused                      it opened but refuses the rate, channels or format
    ├── SceneError (ValueError)                a bad simulated-scene description or WAV file
    └── RequestError (ValueError)              a malformed dedicated-socket request

The components turn these into their declared genom3 exceptions, so that a user
sees ``::capture::NO_SUCH_DEVICE`` with the device and the available devices.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "AudioError", "DeviceNotFound", "UnknownDevicePrefix", "BackendUnavailable",
    "DeviceError", "FormatRefused", "SceneError",
    "RequestError",
]


class AudioError(Exception):
    """Base of every error of the audio library."""


class DeviceNotFound(AudioError, LookupError):
    """The named sound device does not exist.

    Args:
        device: The device string as the user gave it.
        available: What exists instead (device strings the user could pass).
        backend: Which backend looked (``ALSA``, ``PortAudio``, ...).
    """

    def __init__(self, device: str, available: Sequence[str], backend: str) -> None:
        self.device = device
        self.available = list(available)
        self.backend = backend
        listed = ", ".join(self.available) if self.available else "none"
        super().__init__(f"no such {backend} capture device {device!r} (available: {listed})")


class BackendUnavailable(AudioError, ImportError):
    """The Python library a backend needs cannot be imported."""


class DeviceError(AudioError, OSError):
    """The sound device failed while opening, configuring or reading it."""


class FormatRefused(DeviceError):
    """The device opened but refuses the sample rate, channel count or sample format asked for."""


class SceneError(AudioError, ValueError):
    """A simulated scene description or a WAV source that cannot be used."""


class RequestError(AudioError, ValueError):
    """A dedicated-socket request that does not follow ``Read Port - Index <k>``."""


class UnknownDevicePrefix(AudioError, ValueError):
    """A device string whose ``PREFIX:`` names no capture backend (and no ALSA device).

    Attributes:
        device: The device string as given.
        prefix: The part before the colon.
        known: The prefixes that name a backend.
    """

    def __init__(self, device: str, prefix: str, known: list[str]) -> None:
        self.device, self.prefix, self.known = device, prefix, known
        super().__init__(f"no capture backend has the device prefix {prefix!r} (in {device!r}): the prefixes are "
                         f"{', '.join(known)}, and ALSA's own names (hw:1,0, plughw:1,0, default...)")
