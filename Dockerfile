# The gateway on its simulated rig (or on real hardware with --device and --can).
FROM python:3.11-slim

RUN apt-get update \
 && apt-get install -y --no-install-recommends gcc libasound2-dev libportaudio2 \
 && rm -rf /var/lib/apt/lists/*

WORKDIR /opt/aiogenomix
COPY pyproject.toml README.md ./
COPY gateway ./gateway
COPY clients ./clients
COPY components ./components
COPY remote ./remote
COPY record ./record
RUN pip install --no-cache-dir ".[audio,sofa]"

# 8080: the genomix HTTP protocol; 8081: the dedicated audio socket.
EXPOSE 8080 8081
ENTRYPOINT ["aiogenomix-gateway", "--host", "0.0.0.0"]
