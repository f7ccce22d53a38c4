# <torch/torch.h> as a precompiled header, built once and reused by every target
# whose sources include LibTorch. Parsing it costs about three quarters of a
# typical translation unit here (~12 s of ~16 s on one core); loading the
# precompiled header costs about a third of that.
#
# GCC uses a precompiled header only with the position-independence setting and
# the command-line macros it was made with. One small object library carries it,
# with LibTorch's flags and -fPIC: msspr_torch_pch_pic. Every target that reuses it
# compiles with -fPIC too: libraries become position independent, and executables
# get -fPIC in place of the compiler's default -fPIE (they still link as PIE; one
# header of about 35 s instead of two).
#
#   msspr_torch_pch(target ...)   # after the targets are defined
#
# -DMSSPR_PRECOMPILE_TORCH=OFF turns it off (with ccache, or a compiler that
# handles precompiled headers badly); nothing else changes.
include_guard(GLOBAL)

option(MSSPR_PRECOMPILE_TORCH "Precompile <torch/torch.h> once for every target that includes it" ON)

# Makes the header's host; called once, where Torch was found.
function(msspr_torch_pch_hosts)
  if(NOT MSSPR_PRECOMPILE_TORCH)
    return()
  endif()
  add_library(msspr_torch_pch_pic OBJECT ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/torch_pch_host.cc)
  target_link_libraries(msspr_torch_pch_pic PRIVATE ${TORCH_LIBRARIES})
  target_compile_features(msspr_torch_pch_pic PRIVATE cxx_std_17)
  target_precompile_headers(msspr_torch_pch_pic PRIVATE <torch/torch.h>)
  set_target_properties(msspr_torch_pch_pic PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

function(msspr_torch_pch)
  if(NOT MSSPR_PRECOMPILE_TORCH OR NOT TARGET msspr_torch_pch_pic)
    return()
  endif()
  foreach(target ${ARGN})
    get_target_property(type ${target} TYPE)
    if(type STREQUAL "EXECUTABLE")
      target_compile_options(${target} PRIVATE -fPIC)  # POSITION_INDEPENDENT_CODE gives -fPIE
    else()
      set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    endif()
    target_precompile_headers(${target} REUSE_FROM msspr_torch_pch_pic)
  endforeach()
endfunction()
