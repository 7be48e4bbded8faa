# VPR_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer over everything
# we compile (the `sanitize` preset, `make sanitize`). -fno-sanitize-recover
# makes a UBSan report abort like an ASan one, so the test that hit it fails.
# VPR_FUZZ adds the libFuzzer harnesses (tests/fuzz/) to the same build and
# coverage instrumentation to every library, so one build serves both.
# The preset compiles with clang at -O1 with line tables (fast enough for the
# pipeline on real models, stacks with file:line) and without NDEBUG, so
# our assert()s check preconditions too.
option(VPR_SANITIZE "Build with AddressSanitizer and UndefinedBehaviorSanitizer" OFF)
option(VPR_FUZZ "Build the libFuzzer harnesses (needs clang and VPR_SANITIZE)" OFF)

if(VPR_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
  # CGAL's own checks stay off, as in the release build: real models break
  # some of their preconditions where the release build goes on (beast.obj at
  # 5,000 with the paper back half: orientation.h's "!= COPLANAR" in the
  # meshing stage's orientation), and the run is to test the code as shipped.
  add_compile_definitions(CGAL_NDEBUG)
endif()

if(VPR_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang" OR NOT VPR_SANITIZE)
    message(FATAL_ERROR "VPR_FUZZ needs clang and VPR_SANITIZE=ON (use the `sanitize` preset)")
  endif()
  # Coverage for the code under test; only the harnesses link libFuzzer's main.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
