# emonav_drake in a container: `docker build -t emonav .` then `docker run --rm emonav`
# runs `make demo` (the shipped policy walks Digit through a crowd; the replay is written
# inside the container: `docker run --rm -v "$PWD/out:/out" emonav \
#   .venv/bin/emonav sim --plant digit --seed 0 --record /out/demo_replay.html`).
# The tests: `docker run --rm emonav make test`.
#
# Python 3.11 on Debian bookworm, as on the machines the project is developed on. Drake's
# wheel needs only GLib from the system (its other libraries are in the wheel); OpenCV is
# the headless build. torch is installed first from PyTorch's CPU index: the PyPI wheel of
# torch 2.13.0 for Linux is the CUDA build (several GB).
FROM python:3.11-slim-bookworm

RUN apt-get update \
    && apt-get install -y --no-install-recommends make git libglib2.0-0 \
    && rm -rf /var/lib/apt/lists/*

WORKDIR /emonav
COPY pyproject.toml Makefile ./
RUN python3.11 -m venv .venv \
    && .venv/bin/pip install --quiet --upgrade pip \
    && .venv/bin/pip install --quiet torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu

COPY . .
RUN make .venv/.installed

CMD ["make", "demo"]
