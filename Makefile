# padapt -- top-level entry points (CMake does the real work).
#   make demo    install missing packages, build, run the built-in example
#   make check   install missing packages, build (normal + ASan/UBSan), run all tests
#   make build   build only (build/, binary build/bin/padapt)
BUILD      ?= build
ASAN_BUILD ?= build-asan
JOBS       ?= $(shell nproc)
CTEST_JOBS ?= 2

.PHONY: all deps build asan demo check check-fast bench install clean

all: build

deps:
	@bash scripts/install-deps.sh

build: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPADAPT_WERROR=ON
	cmake --build $(BUILD) -j $(JOBS)

asan: deps
	cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DPADAPT_WERROR=ON -DPADAPT_SANITIZE=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS)

demo: build
	@bash scripts/demo.sh $(BUILD)

check: build asan
	ctest --test-dir $(BUILD) --output-on-failure -j $(CTEST_JOBS)
	ctest --test-dir $(ASAN_BUILD) --output-on-failure -j $(CTEST_JOBS) -L sanitize

check-fast: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(CTEST_JOBS)

install: build
	cmake --install $(BUILD)

clean:
	rm -rf $(BUILD) $(ASAN_BUILD)
