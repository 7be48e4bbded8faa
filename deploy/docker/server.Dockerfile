# syntax=docker/dockerfile:1
# vpremesh-server, CPU only (the gRPC front end; with --queue embedded it also
# runs the pipeline on the CPU, rendering through OSMesa or Mesa's EGL).
# From the repository root:
#   docker build -f deploy/docker/server.Dockerfile -t ghcr.io/vpremesh/vpremesh-server:0.1.0 .
# The tag is the project version (CMakeLists.txt); tests/deploy checks that the
# label below, compose and k8s all name the same image.

# Build: the same Debian 12 packages as `make build`, tests off.
FROM debian:12 AS build
ENV DEBIAN_FRONTEND=noninteractive
WORKDIR /src
# The package list alone first, so that editing sources keeps the apt layer.
COPY scripts/install-deps.sh scripts/
RUN bash scripts/install-deps.sh
COPY . .
RUN cmake -S . -B /build -G Ninja -DCMAKE_BUILD_TYPE=Release -DVPR_BUILD_TESTS=OFF -DVPR_CUDA=OFF \
 && cmake --build /build \
 && cmake --install /build --prefix /opt/vpremesh --strip \
 && bash deploy/docker/runtime-libs.sh /opt/runtime /opt/vpremesh/bin/vpremesh-server

# Runtime: only the libraries the binary loads, plus what EGL dlopens on a
# GPU-less host (the Mesa vendor library and its software rasterizer).
FROM debian:12-slim
RUN --mount=type=bind,from=build,source=/opt/runtime/packages.txt,target=/tmp/packages.txt \
    apt-get update -qq \
 && apt-get install -y -qq --no-install-recommends $(cat /tmp/packages.txt) libegl-mesa0 libgl1-mesa-dri \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --system --uid 10001 --no-create-home vpremesh
COPY --from=build /opt/vpremesh/bin/vpremesh-server /opt/vpremesh/bin/
LABEL org.opencontainers.image.ref.name="ghcr.io/vpremesh/vpremesh-server:0.1.0" \
      org.opencontainers.image.version="0.1.0" \
      org.opencontainers.image.title="vpremesh-server"
USER 10001
# gRPC (--listen's default) and the conventional --metrics-listen port.
EXPOSE 50051 50052 9090
# A TCP connect with bash alone: the image has no gRPC health client
# (grpc_health_probe is not in Debian). Kubernetes ignores this and uses its
# native `grpc:` probes against grpc.health.v1 (deploy/k8s/server.yaml).
HEALTHCHECK --interval=10s --timeout=3s --start-period=10s \
  CMD ["bash", "-c", "exec 3<>/dev/tcp/127.0.0.1/50051"]
ENTRYPOINT ["/opt/vpremesh/bin/vpremesh-server"]
