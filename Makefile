# volux — the two commands of the setup promise:
#   make demo   install missing Debian packages, build (Release), render scenes/demo.json
#   make test   install, build (warnings as errors) + run the suite, then the
#               same suite under AddressSanitizer + UBSan
#   make install PREFIX=/opt/volux   build, then install the CLI, headers, libvolux.so/.a,
#               volux.pc, the CMake package and the Python package (docs/API.md)
# Other targets: build, asan, fuzz, bench, clean.

PACKAGES := build-essential cmake pkg-config clang libpng-dev zlib1g-dev libcjson-dev libexpat1-dev \
            libopenexr-dev libcmocka-dev libmicrohttpd-dev libjpeg-dev libgdcm-dev
# Only the tests need these: `locales` has the de_DE sources a test compiles
# into a temporary decimal-comma locale (header numbers must not follow it);
# python3-numpy for the Python package's tests (python/), python3-pip and
# python3-setuptools for its offline `pip install ./python` test; Open MPI
# for the MPI front end's tests (tests/distributed; the CLI is built with
# MPI whenever it is installed); `chromium` runs the viewer's browser test,
# driven by playwright-core from npm (tests/browser/package-lock.json;
# Debian's nodejs + npm unless a node is already installed). Without them
# that one test is skipped. python3-pydicom's test files are real DICOM
# objects the Python tests compare against pydicom's own decoding.
TEST_PACKAGES := locales python3-numpy python3-pip python3-setuptools libopenmpi-dev openmpi-bin chromium \
                 python3-pydicom
NODE_PACKAGES := nodejs npm
JOBS     ?= $(shell nproc 2>/dev/null || echo 2)
BUILD    ?= build
VOLUX    := $(BUILD)/volux
PREFIX   ?= /usr/local

.PHONY: all deps test-deps node-deps build demo test test-release test-asan asan fuzz bench install clean

all: build

# Installs the packages of $(1) that are missing (needs root on a fresh
# machine; a no-op otherwise).
define install_missing
	@missing=""; for p in $(1); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
endef

deps:
	$(call install_missing,$(PACKAGES))

test-deps: deps
	$(call install_missing,$(TEST_PACKAGES))
	@command -v npm >/dev/null || $(MAKE) --no-print-directory node-deps
	@if [ ! -f tests/browser/node_modules/playwright-core/package.json ]; then \
	  (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error) || \
	  echo "warning: npm ci in tests/browser failed: the browser test will be skipped"; \
	fi

node-deps:
	$(call install_missing,$(NODE_PACKAGES))

build: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DVOLUX_WERROR=ON >/dev/null
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	@mkdir -p out
	$(VOLUX) render scenes/demo.json -o out/demo.png
	@echo "wrote out/demo.png"

test: test-release test-asan

# test-deps first: the build then finds MPI and registers its tests.
test-release: test-deps
	$(MAKE) build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

asan: deps
	cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOLUX_WERROR=ON -DVOLUX_SANITIZE=ON >/dev/null
	cmake --build build-asan -j $(JOBS)

test-asan: asan test-deps
	cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j $(JOBS) -LE 'slow|mpi'

# libFuzzer harnesses (clang). Run one: build-fuzz/fuzz/fuzz_nrrd fuzz/corpus/nrrd
fuzz: deps
	CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOLUX_FUZZ=ON -DVOLUX_TESTS=OFF >/dev/null
	cmake --build build-fuzz -j $(JOBS)

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

bench: build
	bench/run.sh

clean:
	rm -rf $(BUILD) build-asan build-fuzz out
