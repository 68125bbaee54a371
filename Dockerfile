# stickslip: FEniCSx (dolfinx 0.9) on Debian trixie, every runtime package from Debian.
#   docker build -t stickslip .
#   docker run --rm -v "$PWD/runs:/work/runs" stickslip stickslip run scenes/figure3_n132.toml --plot
#   docker run --rm stickslip mpirun -n 4 stickslip run scenes/figure3_n132.toml
FROM debian:trixie

ENV DEBIAN_FRONTEND=noninteractive \
    LANG=C.UTF-8 \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    MPLBACKEND=Agg \
    STICKSLIP_OUTPUT=/work/runs

# 1. The Debian stack: the same list ./dev installs into its rootfs (changes rarely: cached layer).
COPY docker/apt-packages.txt /tmp/apt-packages.txt
RUN apt-get update \
 && sed -e 's/#.*//' -e 's/[[:space:]]//g' /tmp/apt-packages.txt | grep -v '^$' \
    | xargs apt-get install -y --no-install-recommends \
 && rm -rf /var/lib/apt/lists/*

# 2. Development tools Debian does not package (ruff), pinned.
COPY docker/dev-requirements.txt /tmp/dev-requirements.txt
RUN python3 -m pip install --no-cache-dir --break-system-packages -r /tmp/dev-requirements.txt

# 3. OpenMPI: shared memory only, quiet on a single node; mpirun also works as root
#    (`docker run --user root ...`).
COPY docker/openmpi-mca-params.conf /etc/openmpi/openmpi-mca-params.conf
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    PRTE_ALLOW_RUN_AS_ROOT=1 PRTE_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_rmaps_base_oversubscribe=1 PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe

# 4. The project itself (changes often: last layers).
RUN useradd --create-home --uid 1000 stickslip && mkdir -p /work/runs && chown stickslip /work/runs
WORKDIR /opt/stickslip
COPY --chown=stickslip . /opt/stickslip
RUN python3 -m pip install --no-cache-dir --no-deps --no-build-isolation --break-system-packages -e .

USER stickslip
WORKDIR /opt/stickslip
CMD ["stickslip", "--help"]
