# Faster builds with the tools Debian offers, each used only where it is installed, so that a
# machine without them still builds (scripts/setup installs both).
#
# ccache: compiled objects kept in the user's cache directory (~/.cache/ccache), so that a
# second build of the same sources, in this tree or in another clone, is mostly cache hits.
# Paths under the source and build trees are hashed relative to them (base_dir), the working
# directory is left out of the debug information's hash (hash_dir), and precompiled headers
# are cached too (pch_defines, time_macros: docs/benchmarks.md, "Build and test times").
option(SKINSPEC_CCACHE "Compile through ccache when it is installed" ON)
if(SKINSPEC_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  find_program(SKINSPEC_CCACHE_PROGRAM ccache)
  if(SKINSPEC_CCACHE_PROGRAM)
    set(CMAKE_CXX_COMPILER_LAUNCHER ${CMAKE_COMMAND} -E env
      CCACHE_BASEDIR=${CMAKE_SOURCE_DIR} CCACHE_NOHASHDIR=1
      CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime
      ${SKINSPEC_CCACHE_PROGRAM})
  endif()
endif()

# mold: links the ~80 test and benchmark programs, each against the static libraries,
# several times faster than GNU ld. GCC 12 takes it as -fuse-ld=mold.
option(SKINSPEC_MOLD "Link with mold when it is installed" ON)
if(SKINSPEC_MOLD)
  include(CheckLinkerFlag)
  check_linker_flag(CXX -fuse-ld=mold SKINSPEC_HAVE_MOLD)
  if(SKINSPEC_HAVE_MOLD)
    add_link_options(-fuse-ld=mold)
  endif()
endif()

# Precompiled headers: the standard library's and the third-party headers a library's files
# include again and again, parsed once per library instead of once per file (parsing was 30-45%
# of a file's compile time; docs/benchmarks.md, "Build and test times"). Each library lists the
# heavy headers it uses beside the common ones; the fit's kernels, compiled with other
# instruction sets and checked to define nothing of their own, are left out.
option(SKINSPEC_PRECOMPILED_HEADERS "Precompile the heavy headers of each library" ON)
set(SKINSPEC_COMMON_PCH <algorithm> <chrono> <cstdint> <functional> <map> <memory> <optional>
  <string> <string_view> <utility> <variant> <vector>)
# With the standard headers precompiled, GCC 12 inlines std::string's operators differently and
# then reports bounds it cannot know inside them (GCC bugs 105329 and 105651): those two
# warnings are off where headers are precompiled, as -Wrestrict is everywhere; a build with
# -DSKINSPEC_PRECOMPILED_HEADERS=OFF has them all.
function(skinspec_precompile target)
  if(SKINSPEC_PRECOMPILED_HEADERS)
    target_precompile_headers(${target} PRIVATE ${SKINSPEC_COMMON_PCH} ${ARGN})
    target_compile_options(${target} PRIVATE $<$<CXX_COMPILER_ID:GNU>:-Wno-array-bounds -Wno-stringop-overflow>
      # clang stamps a precompiled header with its build time, so that ccache would never find
      # again the files compiled with it.
      "$<$<CXX_COMPILER_ID:Clang>:SHELL:-Xclang -fno-pch-timestamp>")
  endif()
endfunction()
