# Two commands do all the set-up on a fresh Debian 12 machine:
#   make run    install dependencies, build, start the main job
#   make test   install dependencies, build, run every test with ctest
# make bench runs the main benchmarks and rewrites the tables of bench/README.md (bench/run_all.sh).
# make options rewrites what the option registry generates: api/openapi.yaml's and
# api/schemas/JobOptions.json's job options, docs/options.md and the Python client's
# JOB_OPTIONS (scripts/gen_options.py).
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: deps build run test test-asan bench options clean
deps:
	bash scripts/install-deps.sh

build: deps
	cmake -S . -B $(BUILD) -G Ninja $(CMAKE_FLAGS)
	cmake --build $(BUILD) -j $(JOBS)

run: build
	bash scripts/run.sh $(BUILD)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# Address/UB sanitizer build of the engine and its unit tests (the Python tests stay on the release build).
# -O1: unoptimised Eigen under ASan made the convergence test take over 6 minutes.
test-asan: deps
	cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" -DHOCURVE_SANITIZE=ON
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=0 ctest --output-on-failure -j $(JOBS) -LE "python|slow"

# The main benchmarks in one go, from one build: outputs in bench/results/, tables into bench/README.md.
# BENCH_ARGS=--all adds the long sweeps; BENCH_ARGS=--no-readme leaves bench/README.md alone.
bench: build
	bash bench/run_all.sh $(BUILD) $(BENCH_ARGS)

options: deps
	cmake -S . -B $(BUILD) -G Ninja $(CMAKE_FLAGS)
	cmake --build $(BUILD) -j $(JOBS) --target hocurve
	/usr/bin/python3 scripts/gen_options.py $(BUILD)

clean:
	rm -rf $(BUILD) build-asan
