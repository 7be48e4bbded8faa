# vpremesh: `make demo` and `make test` work as root on a fresh Debian 12 machine.
BUILD ?= build/release
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
MODEL ?= ../shared/models/horse.ply
TARGET ?= 5000
DEMO_OUT ?= out/demo
FUZZ_SECONDS ?= 60

.PHONY: all deps configure build test demo sanitize fuzz clean format

all: build

deps:
	@bash scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD) -j$(JOBS)

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS) --timeout 900

# AddressSanitizer + UBSan build of the pipeline's tests in build/sanitize
# (scripts/sanitize.sh); any report fails it.
sanitize:
	@bash scripts/sanitize.sh

# Each libFuzzer target for FUZZ_SECONDS (docs/fuzzing.md).
fuzz:
	@bash scripts/fuzz.sh $(FUZZ_SECONDS)

demo: build
	@bash scripts/demo.sh $(BUILD) $(MODEL) $(TARGET) $(DEMO_OUT)

format:
	@find worker client tests -name '*.h' -o -name '*.cpp' -o -name '*.cu' | xargs clang-format -i

clean:
	@rm -rf build out
