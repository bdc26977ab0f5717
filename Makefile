# BTF Studio — the two commands of the README, plus helpers.
#   make demo   install missing packages, build Release, simulate the default scene into out/
#   make test   install missing packages, build, run every test with ctest
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: all deps build venv demo test bench clean studio screenshots sanitize fuzz tsan

all: build

deps:
	@bash scripts/install-deps.sh

$(BUILD_DIR)/build.ninja: CMakeLists.txt
	cmake -S . -B $(BUILD_DIR) -G Ninja $(CMAKE_FLAGS)

build: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS)

demo: build
	@bash scripts/demo.sh $(BUILD_DIR)

# The desktop app on the demo scene (needs a display; see docs/studio.md for headless use).
studio: build
	$(BUILD_DIR)/app/btfstudio resources/scenes/brick.json

# The README's screenshots from a scripted session under Xvfb.
screenshots: build
	bash scripts/studio-screenshots.sh $(BUILD_DIR) docs/images

# The project's venv for the Mitsuba 3 plugin (pinned, from PyPI; docs/python.md).
venv: build
	bash scripts/python-venv.sh $(BUILD_DIR)

test: build venv
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

# The engine's tests under AddressSanitizer + UndefinedBehaviorSanitizer with leak checking
# (suppressions, each with its reason: tests/lsan.supp). Not part of `make test` (a full
# rebuild and ~3x slower tests); see docs/performance.md. Built without MPI (Open MPI's own
# allocations would drown the leak report): the engine's tests then run the no-MPI build.
sanitize: deps
	cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBTF_SANITIZE=ON \
	  -DBTF_BUILD_UI=OFF -DBTF_MPI=OFF
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0 \
	  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ctest --output-on-failure -j $(JOBS)

# libFuzzer targets, one per reader (clang from Debian; docs/reliability.md): builds build-fuzz/
# (engine + targets, ASan + UBSan + coverage) and runs each target FUZZ_SECONDS seconds on every
# core. Findings land in build-fuzz/fuzz-findings/TARGET/; a table in build-fuzz/fuzz-summary.md.
FUZZ_SECONDS ?= 120
FUZZ_TARGETS ?=
fuzz:
	@bash scripts/install-deps.sh fuzz
	CC=clang-14 CXX=clang++-14 cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DBTF_FUZZ=ON -DBTF_BUILD_UI=OFF -DBTF_BUILD_TESTS=OFF
	cmake --build build-fuzz -j $(JOBS)
	bash scripts/fuzz.sh build-fuzz $(FUZZ_SECONDS) $(FUZZ_TARGETS)

# ThreadSanitizer over the threaded kernels (parallel loops on instrumented std::threads instead
# of TBB's uninstrumented scheduler, see engine/btf/core/parallel.cpp), the studio's job queue and
# preview thread (no GL), and the btfsim runs the CLI tests start. Suppressions with their
# reasons: tests/tsan.supp. Not part of `make test` (a full rebuild, tests ~10x slower).
TSAN_ENGINE_TESTS ?= Adaptive.*:Direct.*:Network.*:PathTracer.*:Codecs.*:Energy.*:Ops.*:BtfStore.*
TSAN_UI_TESTS ?= Jobs.*:Preview.*:JobRequests.*
tsan: deps
	cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O1 -g1" -DBTF_TSAN=ON \
	  -DBTF_MPI=OFF
	cmake --build build-tsan -j $(JOBS) --target engine_tests ui_tests btfsim btfstudio
	cd build-tsan && export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$(CURDIR)/tests/tsan.supp" && \
	  tests/engine_tests --gtest_filter='$(TSAN_ENGINE_TESTS)' && tests/ui_tests --gtest_filter='$(TSAN_UI_TESTS)'

bench: build
	$(BUILD_DIR)/app/btfsim bench resources/scenes/brick.json --spp 1 --bounces 1
	$(BUILD_DIR)/app/btfsim bench resources/scenes/brick.json --spp 2 --bounces 3 --shadows map --repeat 1

clean:
	rm -rf $(BUILD_DIR) build-asan build-fuzz build-tsan out
