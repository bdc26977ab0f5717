# BTF Studio — the two commands of the README, plus helpers.
#   make demo   install missing packages, build Release, simulate the default scene into out/
#   make test   install missing packages, build, run every test with ctest
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release

.PHONY: all deps build demo test bench clean studio screenshots

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

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

bench: build
	$(BUILD_DIR)/app/btfsim bench resources/scenes/brick.json --bounces 1
	$(BUILD_DIR)/app/btfsim bench resources/scenes/brick.json --spp 2 --bounces 3 --shadows map --repeat 1

clean:
	rm -rf $(BUILD_DIR) out
