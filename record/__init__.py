"""``aiogenomix-record``: record a gateway's ports over HTTP into MCAP, and export recordings to WAV and CSV.

A tool on both sides of the wire: it speaks the gateway's public protocol through the client
(:mod:`aiogenomix.clients`) and writes with the recording library
(:mod:`aiogenomix.components.recording`), as the ``recorder`` component does next to the hardware.
"""

from ._command import ProgressLine, main
from ._over_http import PortNotFound, record_over_http

__all__ = ["main", "record_over_http", "PortNotFound", "ProgressLine"]
