# Build options. Each has a default that works on a fresh Debian 12 machine.
option(VPR_BUILD_TESTS "Build the GoogleTest suite" ON)
option(VPR_EGL "Render snapshots through EGL (NVIDIA or Mesa devices)" ON)
option(VPR_OSMESA "Render snapshots through OSMesa (off for the small GPU bundle)" ON)
set(VPR_CUDA "AUTO" CACHE STRING "Build the CUDA twins: AUTO (when nvcc is found), ON or OFF")
set_property(CACHE VPR_CUDA PROPERTY STRINGS AUTO ON OFF)

if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  set(CMAKE_BUILD_TYPE RelWithDebInfo CACHE STRING "" FORCE)
endif()
set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_POSITION_INDEPENDENT_CODE ON)
set(CMAKE_EXPORT_COMPILE_COMMANDS ON)

# ccache, when installed, makes rebuilds in several build folders cheap.
find_program(VPR_CCACHE ccache)
if(VPR_CCACHE)
  set(CMAKE_CXX_COMPILER_LAUNCHER ${VPR_CCACHE})
  set(CMAKE_CUDA_COMPILER_LAUNCHER ${VPR_CCACHE})
endif()
