# stickslip: FEniCSx (dolfinx 0.9) on Debian trixie; the runtime image needs nothing outside
# Debian (no PyPI request).  Stages: `stack` (the Debian packages), `dev` (+ ruff, for
# development in a container), `runtime` (the default, last: stack + the project, installed).
#   docker build -t stickslip .
#   docker run --rm -v "$PWD/runs:/work/runs" stickslip stickslip run scenes/figure3_n132.toml --plot
#   docker run --rm -v "$PWD/runs:/work/runs" stickslip mpirun -n 4 stickslip run scenes/figure3_n132.toml
#   docker build --target dev -t stickslip-dev .     # ruff from PyPI (see the dev stage)
# Proven by docker/test-image.sh (CI); details and the podman equivalent: docs/docker.md.
FROM debian:trixie AS stack

ENV DEBIAN_FRONTEND=noninteractive \
    LANG=C.UTF-8 \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    MPLBACKEND=Agg \
    STICKSLIP_OUTPUT=/work/runs

# 1. The Debian stack: the same list ./dev installs into its rootfs (changes rarely: cached layer).
#    Users need no manuals, documentation or translations: dpkg never unpacks them (copyright
#    files stay); apt's lists and downloaded packages leave in the same layer.
COPY docker/apt-packages.txt /tmp/apt-packages.txt
RUN printf '%s\n' 'path-exclude=/usr/share/doc/*' 'path-include=/usr/share/doc/*/copyright' \
        'path-exclude=/usr/share/man/*' 'path-exclude=/usr/share/info/*' \
        'path-exclude=/usr/share/locale/*' 'path-include=/usr/share/locale/locale.alias' \
        'path-exclude=/usr/share/lintian/*' >/etc/dpkg/dpkg.cfg.d/stickslip-nodoc \
 && apt-get update \
 && sed -e 's/#.*//' -e 's/[[:space:]]//g' /tmp/apt-packages.txt | grep -v '^$' \
    | xargs apt-get install -y --no-install-recommends \
 && apt-get clean \
 && rm -rf /var/lib/apt/lists/* /var/log/apt /var/log/dpkg.log /var/cache/debconf/*-old

# 2. OpenMPI: shared memory only, quiet on a single node; mpirun also works as root
#    (`docker run --user root ...`) and with more ranks than cores; its session directory in
#    /tmp (not $TMPDIR: an unusable TMPDIR then gets stickslip's one-line check, not a PMIx box).
COPY docker/openmpi-mca-params.conf /etc/openmpi/openmpi-mca-params.conf
#    ADIOS2_ALWAYS_USE_MPI: Debian ships only the MPI bindings of adios2, so `import adios2`
#    (reading fields.bp in Python) needs it.
#    mpirun itself is docker/bin/mpirun (first on PATH; the same one ./dev uses): Open MPI's,
#    with SIGTERM/SIGINT/SIGHUP given to the ranks (they save; mpirun returns when they are
#    done, exit 130, one line), and one line when HOME is unset.
COPY --chmod=0755 docker/bin/mpirun /usr/local/bin/mpirun
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    PRTE_ALLOW_RUN_AS_ROOT=1 PRTE_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_rmaps_base_oversubscribe=1 PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe \
    PRTE_MCA_prte_tmpdir_base=/tmp \
    ADIOS2_ALWAYS_USE_MPI=1

# 3. The non-root user and the output directory it owns (mount a host directory there).
RUN useradd --create-home --uid 1000 stickslip && mkdir -p /work/runs && chown stickslip /work/runs


# Development image (not built by `docker build .`): + the tools Debian does not package (ruff),
# from PyPI.  Mount the repository and use ./dev, which runs natively where dolfinx imports:
#   docker build --target dev -t stickslip-dev .
#   docker run --rm -v "$PWD:/src" -w /src stickslip-dev ./dev bash tests/run.sh
# Behind a TLS-inspecting proxy, hand pip the host's CA bundle (used for this step only):
#   docker build --target dev --secret id=hostca,src=/etc/ssl/certs/ca-certificates.crt ...
FROM stack AS dev
COPY docker/dev-packages.txt /tmp/dev-packages.txt
RUN apt-get update \
 && sed -e 's/#.*//' -e 's/[[:space:]]//g' /tmp/dev-packages.txt | grep -v '^$' \
    | xargs apt-get install -y --no-install-recommends \
 && apt-get clean && rm -rf /var/lib/apt/lists/*
COPY docker/dev-requirements.txt /tmp/dev-requirements.txt
RUN --mount=type=secret,id=hostca,required=false \
    if [ -s /run/secrets/hostca ]; then export PIP_CERT=/run/secrets/hostca; fi \
 && python3 -m pip install --no-cache-dir --break-system-packages --root-user-action=ignore \
        -r /tmp/dev-requirements.txt
CMD ["bash"]


# Runtime image (the default): the project installed normally (not editable: the image is
# what users run, nothing in it changes), with --no-index so that pip cannot reach any index.
# pyproject.toml's package-dir installs the folders solver/, cli/, ... as stickslip.solver,
# stickslip.cli, ... The source tree stays in /opt/stickslip for its scenes/, sweeps/, docs/
# and tests/, less its stickslip/ folder: that folder holds only the package's root (the
# subpackages are the folders beside it), and from the working directory (first on sys.path
# for `python3 -c` and `python3 -m`) it would hide the installed package. The installed code
# finds the shipped scenes (`stickslip run figure3_n36`) through STICKSLIP_SCENES.
FROM stack AS runtime
ENV STICKSLIP_SCENES=/opt/stickslip/scenes
COPY . /opt/stickslip
RUN python3 -m pip install --no-index --no-cache-dir --no-deps --no-build-isolation \
        --break-system-packages --root-user-action=ignore /opt/stickslip \
 && rm -rf /opt/stickslip/build /opt/stickslip/*.egg-info /opt/stickslip/stickslip

USER stickslip
WORKDIR /opt/stickslip
# Warm the user's caches (~/.cache: dolfinx's compiled forms, numba's step kernels) with one
# short run of the shipped P1-triangle explicit scenes' kind: containers start with them.
RUN stickslip run smoke -o /tmp/warm-up --set time.end_time=0.001 >/dev/null && rm -rf /tmp/warm-up
CMD ["stickslip", "--help"]
