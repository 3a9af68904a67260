# raycastd on Debian 12: a build stage with scripts/setup.sh's build packages, and a slim
# runtime stage with only the shared libraries the binary links, run as a non-root user.
#   docker build -t raycastd .
#   docker run -p 8080:8080 -v raycastd-data:/data -v "$PWD/models:/models:ro" \
#       -e RAYCASTD_TOKEN=change-me raycastd
# Configuration is by flags after the image name or by RAYCASTD_<OPTION> variables (every
# option with a value; raycastd --help). docs/deploy.md has the sizing and the nginx and
# Kubernetes set-ups. tests/deploy/test_dockerfile.py keeps both package lists honest: the
# build list must equal scripts/setup.sh's build_packages, the runtime list must name the
# packages owning the libraries the built binary links (ldd), nothing more.

FROM debian:12 AS build
# The package list is scripts/setup.sh's build_packages, written out so that Docker caches
# this layer apart from the sources.
RUN apt-get update -q \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        build-essential cmake ninja-build pkg-config git curl ca-certificates \
        libembree-dev libtinygltf-dev libopenmesh-dev libcpp-httplib-dev libssl-dev \
        nlohmann-json3-dev libstb-dev zlib1g-dev libtbb-dev libgtest-dev libgmock-dev libbenchmark-dev \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY . .
RUN cmake --preset release -DBUILD_TESTING=OFF -DRAYCASTD_BUILD_BENCH=OFF \
    && cmake --build --preset release -j"$(nproc)" --target raycastd \
    && strip build/release/server/raycastd

FROM debian:12-slim AS runtime
# The runtime halves of the -dev packages above that raycastd links (ldd of the binary).
RUN apt-get update -q \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        libembree3-3 libtbb12 libtinygltf2d libstb0 libcpp-httplib0.11 libssl3 libbrotli1 \
        libopenmesh1 zlib1g libstdc++6 libgcc-s1 \
    && rm -rf /var/lib/apt/lists/*
# A system user with no shell and no home: the server needs to write /data only.
RUN useradd --system --uid 10001 --no-create-home --home-dir /nonexistent \
        --shell /usr/sbin/nologin raycastd \
    && mkdir -p /data /models \
    && chown raycastd:raycastd /data
COPY --from=build /src/build/release/server/raycastd /usr/local/bin/raycastd
COPY --from=build /src/clients/web /usr/share/raycastd/web
COPY --from=build /src/clients/examples /usr/share/raycastd/examples
ENV RAYCASTD_HOST=0.0.0.0 \
    RAYCASTD_PORT=8080 \
    RAYCASTD_DATA_DIR=/data \
    RAYCASTD_SCENE_ROOT=/models \
    RAYCASTD_WEB_ROOT=/usr/share/raycastd/web \
    RAYCASTD_LOG_LEVEL=info
USER raycastd
VOLUME ["/data", "/models"]
EXPOSE 8080
# The binary asks itself (GET /v1/health on RAYCASTD_PORT): the slim image has no curl.
HEALTHCHECK --interval=10s --timeout=5s --start-period=10s --retries=3 \
    CMD ["raycastd", "--health-check"]
ENTRYPOINT ["raycastd"]
CMD []
