# A faster linker than GNU ld (bfd) where the toolchain has one: gold (part of binutils), else
# lld. Every msspr executable links LibTorch, and bfd spends most of a link reading its symbols:
# msspr_core_model_test linked in 0.86-0.95 s with bfd and 0.09-0.10 s with gold or lld (2-core
# Intel Xeon, family 6 model 207), and make build links about 50 executables. The output is the
# same program. -DMSSPR_FAST_LINKER=OFF keeps the compiler's default linker.
option(MSSPR_FAST_LINKER "Link with gold or lld when the compiler accepts -fuse-ld for them" ON)
if(MSSPR_FAST_LINKER AND NOT MSSPR_FAST_LINKER_CHECKED)
  set(MSSPR_FAST_LINKER_CHECKED ON)
  include(CheckCXXSourceCompiles)
  foreach(linker gold lld)
    set(CMAKE_REQUIRED_LINK_OPTIONS -fuse-ld=${linker})
    check_cxx_source_compiles("int main() { return 0; }" MSSPR_LINKER_${linker}_WORKS)
    unset(CMAKE_REQUIRED_LINK_OPTIONS)
    if(MSSPR_LINKER_${linker}_WORKS)
      add_link_options(-fuse-ld=${linker})
      message(STATUS "msspr: linking with ${linker} (-DMSSPR_FAST_LINKER=OFF for the default)")
      break()
    endif()
  endforeach()
endif()
