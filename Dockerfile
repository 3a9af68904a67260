# raycastd on Debian 12, built with the project's own setup script.
#   docker build -t raycastd . && docker run -p 8080:8080 raycastd
FROM debian:12
WORKDIR /src
COPY scripts/setup.sh scripts/setup.sh
RUN scripts/setup.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN cmake --preset release -DBUILD_TESTING=OFF -DRAYCASTD_BUILD_BENCH=OFF \
    && cmake --build --preset release -j"$(nproc)" --target raycastd
EXPOSE 8080
VOLUME /data
CMD ["build/release/server/raycastd", "--host", "0.0.0.0", "--port", "8080", "--data-dir", "/data", \
     "--scene-root", "/models", "--demo", "clients/examples/tutorial-spheres.json"]
