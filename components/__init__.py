"""The GenoM3-like component runtime (``core``) and the components hosted by the gateway."""
