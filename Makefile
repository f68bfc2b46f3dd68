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

.PHONY: deps build run test test-asan fuzz bench options clean
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

# libFuzzer harnesses of every reader (STL, OBJ, PLY, OFF, .msh, gzip) under ASan/UBSan, built with
# clang, FUZZ_SECONDS each; fails on any crash, hang, leak, UB or non-InputError exception.
FUZZ_SECONDS ?= 60
fuzz: deps
	cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 -DHOCURVE_FUZZ=ON -DHOCURVE_TESTS=OFF
	cmake --build build-fuzz -j $(JOBS) --target fuzz_harnesses
	bash tests/fuzz/run.sh build-fuzz $(FUZZ_SECONDS)

clean:
	rm -rf $(BUILD) build-asan build-fuzz
