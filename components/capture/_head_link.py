"""Where the simulated scene finds the head azimuth: the host's simulated KEMAR drive, if any."""

from __future__ import annotations

from ..core import ComponentHost
from ._backend import Azimuth

__all__ = ["simulated_head_azimuth"]


def simulated_head_azimuth(host: ComponentHost) -> Azimuth | None:
    """The azimuth (degrees, positive = left) of the host's simulated KEMAR head, or None.

    There is a simulated head when the host's CAN bus is ``virtual``; the drive is
    shared through the host (``kemar.rig``), so the scene turns when the ``kemar``
    or ``kemarcapture`` component moves the head.  On a real bus there is none
    (and real microphones hear the real room).
    """
    # Imported here: plain capture must not pay for the CAN stack unless it simulates.
    from ..kemar import simulated_rig

    rig = simulated_rig(host)
    if rig is None:
        return None
    return lambda: rig.head_azimuth
