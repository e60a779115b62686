# nc_dolfinx in a container, installed exactly as CI installs it (install.sh).
#   docker build -t nc_dolfinx .                          # Debian trixie (DOLFINx 0.9), the current stable
#   docker build --build-arg RELEASE=sid -t nc_dolfinx .  # or sid (DOLFINx 0.11), bookworm (0.5.2)
#   docker run --rm -v "$PWD/results:/nc_dolfinx/results" nc_dolfinx            # the default case, 2 ranks
#   docker run --rm nc_dolfinx /usr/bin/python3 -m pytest                        # the test suite
ARG RELEASE=trixie
FROM debian:${RELEASE}
WORKDIR /nc_dolfinx
COPY install.sh .
RUN sh install.sh && rm -rf /var/lib/apt/lists/*
COPY . .
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
# Warm the FFCx JIT cache so that the first run does not compile.
RUN /usr/bin/python3 run_cases.py block --refine none --out /tmp/warmup --quiet && rm -rf /tmp/warmup
CMD ["mpirun", "-n", "2", "/usr/bin/python3", "run_cases.py"]
