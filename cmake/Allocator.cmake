# The programs' allocator: gperftools' tcmalloc (libtcmalloc-minimal4, from
# libgoogle-perftools-dev) in place of glibc's malloc. The back half builds and
# drops many large arrays per job (the refinement, the CVT, the dual), and
# glibc hands those back to the kernel and faults them in again. On an H100
# host (docs/performance.md, 2026-11-28) tcmalloc made igea -> 10,000 and
# horse -> 5,000 12-15% faster end to end and eight jobs at once 5% more
# jobs/s; jemalloc and mimalloc gained nothing there. Only the programs link
# it (the libraries and tests keep the system's), and never under the
# sanitizers, which replace malloc themselves.
option(VPR_TCMALLOC "Link the programs with tcmalloc (gperftools)" ON)
if(VPR_TCMALLOC AND NOT VPR_SANITIZE)
  find_library(VPR_TCMALLOC_LIBRARY tcmalloc_minimal)
  if(NOT VPR_TCMALLOC_LIBRARY)
    message(WARNING "vpremesh: tcmalloc not found (libgoogle-perftools-dev): the programs use glibc's malloc")
  endif()
endif()

# Links `target` (a program) with the allocator above. --no-as-needed: nothing
# names tcmalloc's symbols, it replaces malloc by being loaded first.
function(vpr_program_allocator target)
  if(VPR_TCMALLOC AND NOT VPR_SANITIZE AND VPR_TCMALLOC_LIBRARY)
    target_link_libraries(${target} PRIVATE "-Wl,--push-state,--no-as-needed" ${VPR_TCMALLOC_LIBRARY}
                                            "-Wl,--pop-state")
    # GCC may otherwise fold a malloc/free pair it can see into nothing or
    # into its own builtins (gperftools' README).
    target_compile_options(${target} PRIVATE -fno-builtin-malloc -fno-builtin-calloc -fno-builtin-realloc
                                             -fno-builtin-free)
  endif()
endfunction()
