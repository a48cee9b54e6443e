"""Every capture source a device string can name on this machine (for ``ListDevices`` and error messages)."""

from __future__ import annotations

import logging

from ._errors import BackendUnavailable

__all__ = ["list_capture_devices"]

log = logging.getLogger(__name__)


def list_capture_devices() -> list[str]:
    """The device strings a capture can open here: ``sim``, then ALSA's, then PortAudio's.

    A backend whose library is missing contributes nothing (and says so in the
    log); WAV files (``file:<path.wav>``) and scene files (``sim:<scene.json>``)
    are named by path and not listed.  This talks to the sound libraries, which
    may block: call it off the event loop.
    """
    from ._alsa import alsa_capture_devices
    from ._portaudio import portaudio_capture_devices

    devices = ["sim"]
    for kind, lister in (("ALSA", alsa_capture_devices), ("PortAudio", portaudio_capture_devices)):
        try:
            devices.extend(name for name in lister() if name not in devices)
        except BackendUnavailable as exc:
            log.info("no %s devices listed: %s", kind, exc)
    return devices
