# syntax=docker/dockerfile:1
# vpremesh-worker for NVIDIA GPUs: CUDA stages, EGL rendering on the GPU.
# From the repository root:
#   docker build -f deploy/docker/worker.Dockerfile -t ghcr.io/vpremesh/vpremesh-worker:0.1.0 .
#
# Why Debian 12 and not nvidia/cuda:13.0.x-runtime-ubuntu24.04: the binary links
# Debian 12's gRPC, protobuf, Draco, TBB and hiredis by soname, and the project
# builds only against Debian 12 (scripts/install-deps.sh); on Ubuntu those
# sonames differ. The only CUDA library it needs at run time is libcudart.so.13,
# copied from the build stage; the driver (libcuda, NVIDIA's EGL) is mounted
# from the host by the NVIDIA container toolkit.

# Build: Debian 12 packages plus nvcc and the CUDA runtime from NVIDIA's debian12
# repository. OSMesa off: on a GPU node EGL renders on the GPU, and OSMesa
# would drag LLVM into the image.
FROM debian:12 AS build
ARG CUDA_PACKAGE_VERSION=13-0
# sm_90 (H100/H200), as CMakePresets.json's device preset; e.g. "80;90" for A100 too.
ARG CUDA_ARCHITECTURES=90
ENV DEBIAN_FRONTEND=noninteractive
WORKDIR /src
ADD https://developer.download.nvidia.com/compute/cuda/repos/debian12/x86_64/cuda-keyring_1.1-1_all.deb /tmp/
RUN dpkg -i /tmp/cuda-keyring_1.1-1_all.deb \
 && apt-get update -qq \
 && apt-get install -y -qq --no-install-recommends \
      cuda-nvcc-${CUDA_PACKAGE_VERSION} cuda-cudart-dev-${CUDA_PACKAGE_VERSION} cuda-cccl-${CUDA_PACKAGE_VERSION}
COPY scripts/install-deps.sh scripts/
RUN bash scripts/install-deps.sh
COPY . .
RUN nvcc=$(ls -d /usr/local/cuda-*/bin/nvcc | head -1) \
 && cmake -S . -B /build -G Ninja -DCMAKE_BUILD_TYPE=Release -DVPR_BUILD_TESTS=OFF \
      -DVPR_CUDA=ON -DVPR_OSMESA=OFF -DCMAKE_CUDA_COMPILER="$nvcc" -DCMAKE_CUDA_ARCHITECTURES="${CUDA_ARCHITECTURES}" \
 && cmake --build /build \
 && cmake --install /build --prefix /opt/vpremesh --strip \
 && LD_LIBRARY_PATH=$(dirname "$(dirname "$nvcc")")/lib64 \
      bash deploy/docker/runtime-libs.sh /opt/runtime /opt/vpremesh/bin/vpremesh-worker

# Runtime: the libraries the binary loads plus the GL loaders (libglvnd) that
# dispatch to the NVIDIA EGL vendor library the toolkit mounts.
FROM debian:12-slim
RUN --mount=type=bind,from=build,source=/opt/runtime/packages.txt,target=/tmp/packages.txt \
    apt-get update -qq \
 && apt-get install -y -qq --no-install-recommends $(cat /tmp/packages.txt) \
      libglvnd0 libegl1 libgl1 libopengl0 libgles2 \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --system --uid 10001 --no-create-home vpremesh
COPY --from=build /opt/runtime/lib/ /opt/vpremesh/lib/
COPY --from=build /opt/vpremesh/bin/vpremesh-worker /opt/vpremesh/bin/
# The toolkit mounts the driver only for the capabilities named here: graphics
# brings libEGL_nvidia and its vendor file, without which EGL has no device.
# /usr/local/nvidia is where GKE-style driver installers put the same files.
ENV NVIDIA_VISIBLE_DEVICES=all \
    NVIDIA_DRIVER_CAPABILITIES=compute,graphics,utility \
    NVIDIA_REQUIRE_CUDA="cuda>=13.0" \
    LD_LIBRARY_PATH=/opt/vpremesh/lib:/usr/local/nvidia/lib64 \
    __EGL_VENDOR_LIBRARY_DIRS=/etc/glvnd/egl_vendor.d:/usr/share/glvnd/egl_vendor.d:/usr/local/nvidia/share/glvnd/egl_vendor.d
LABEL org.opencontainers.image.ref.name="ghcr.io/vpremesh/vpremesh-worker:0.1.0" \
      org.opencontainers.image.version="0.1.0" \
      org.opencontainers.image.title="vpremesh-worker"
USER 10001
# --metrics-listen's conventional port (the worker serves no gRPC).
EXPOSE 9090
ENTRYPOINT ["/opt/vpremesh/bin/vpremesh-worker"]
