"""What the gateway checks and says at start for a new user (issue 13): a taken audio socket port is found at once."""

from __future__ import annotations

import socket

from aiogenomix.gateway._run import _port_taken


def test_a_taken_audio_socket_port_is_found_at_start() -> None:
    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        port = other.getsockname()[1]
        assert _port_taken("127.0.0.1", port)                # another program holds it: said at start
    assert _port_taken("127.0.0.1", port) is None            # free again
    assert _port_taken("127.0.0.1", 0) is None               # 0: a free port at each DedicatedSocket
