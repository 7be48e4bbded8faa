# Helpers that keep each part of the pipeline a small target of its own.

# vpr_library(NAME SOURCES ... DEPS ...): one static library per pipeline part,
# so that a stage and its test build on their own.
function(vpr_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR}/worker)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  target_compile_options(${name} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra>)
endfunction()

# vpr_test(NAME SOURCES ... LIBS ... [LABELS ...]): one GoogleTest executable,
# registered with ctest and run from the repository root (models are found
# at ../shared/models relative to it).
function(vpr_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  # `make sanitize` builds and runs the tests defined while VPR_SANITIZE_THESE
  # is on (tests/CMakeLists.txt).
  if(VPR_SANITIZE AND VPR_SANITIZE_THESE)
    list(APPEND ARG_LABELS sanitize)
    set_property(GLOBAL APPEND PROPERTY VPR_SANITIZE_TARGETS ${name})
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/worker ${PROJECT_SOURCE_DIR}/tests)
  gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} TEST_LIST ${name}_TESTS
                       DISCOVERY_TIMEOUT 120)
  # Labels are set by a script ctest runs after the discovered tests are
  # added: gtest_discover_tests' PROPERTIES cannot carry a list ("cpu;redis").
  set(_labels ${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake)
  file(WRITE ${_labels} "set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"${ARG_LABELS}\")\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${_labels})
endfunction()
